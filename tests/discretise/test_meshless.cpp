// The meshless model: tables, volumes, statistics, F at rest, patch test, thin parts.
#include "discretise/meshless.hpp"
#include "discretise/level_set.hpp"
#include "discretise/voxel_domain.hpp"
#include "discretise/surface_quadrature.hpp"
#include "mechanics/elasticity.hpp"
#include "mechanics/frame_sample.hpp"
#include "model/state.hpp"
#include "support/meshless_fixtures.hpp"

#include <catch2/catch.hpp>

#include <utility>

using namespace fascia;
using namespace fascia::test;

namespace {

constexpr double kPositionTolerance = 1e-14;  // m: affine_errors

PairTableView view(const Model& m) {
  const NeighbourTable& nb = m.neighbours;
  return PairTableView{nb.offsets.data(), nb.frames.data(), nb.weights.data(), nb.weight_gradients.data(),
                       nb.rest_offsets.data()};
}

// Largest |F - A| (Frobenius) and |p - (A p_rest + t)| over samples when frames move affinely
// with R = I. p = sum_i w_i (x_i + R l_i) reproduces A p_rest + t exactly in exact arithmetic
// (partition of unity and linear completeness of the weights); in floating point its error is
// the sum's rounding, at most (n + 3) u sum_i |w_i| |x_i + l_i| (Higham, Accuracy and Stability
// of Numerical Algorithms, 2nd ed., eq. 3.5; u = 1.1e-16), plus the weights' own reproduction
// defects (round-off of their 4 x 4 moment solves) times |A - I| |p| and |p|. In the boxes below
// n <= 24 neighbours, sum_i |w_i| <= 2.9 (weights near the boundary are negative) and
// |x_i + l_i| <= 0.26 m, so the sum's part is at most 2.2e-15 m: kPositionTolerance = 1e-14 m
// leaves room for the weights' part (at most 1.2e-15 m in all seen), and an offset l_i wrong by
// a micrometre, or a weight by 1e-12, exceeds it.
void affine_errors(const Model& model, const Mat3& A, const Vec3& t, double& f_error, double& p_error) {
  State s = rest_state(model);
  for (int i = 0; i < model.frame_count(); ++i)
    store3(&s.positions[3 * i], A * load3(&model.frame_rest_positions[3 * i]) + t);
  std::vector<double> R;
  rotation_matrices(s, R);
  f_error = p_error = 0;
  for (int sm = 0; sm < model.sample_count(); ++sm) {
    const Mat3 F = sample_deformation_gradient(view(model), sm, s.positions.data(), R.data());
    f_error = std::max(f_error, std::sqrt(ddot(F - A, F - A)));
    const Vec3 p = sample_position(view(model), sm, s.positions.data(), R.data());
    p_error = std::max(p_error, norm(p - (A * load3(&model.samples.rest_positions[3 * sm]) + t)));
  }
}

}  // namespace

TEST_CASE("meshless model: valid tables, volumes summing to the object, statistics", "[discretise][meshless]") {
  const MeshlessBuild b = small_meshless_box();
  const Model& m = b.model;
  REQUIRE_NOTHROW(validate(m));
  const MeshlessStatistics& st = b.statistics;
  INFO(st.describe());
  REQUIRE(st.frames == m.frame_count());
  REQUIRE(st.samples == m.sample_count());
  REQUIRE(st.frames >= 10);
  REQUIRE(st.samples > 5 * st.frames);
  // Every frame whose support covers the sample: about 20 inside a Poisson-disk cloud with the
  // default supports (1.6 times the 8th-neighbour distance), fewer at the boundary; MLS needs 4.
  REQUIRE(st.neighbours_min >= 6);
  REQUIRE(st.neighbours_mean > 12);
  REQUIRE(st.added_frames == 0);
  REQUIRE(st.integration_defect <= 1e-11);
  REQUIRE(st.min_spread >= 0.15);
  // Box 0.2 x 0.1 x 0.05 (area 0.07 m^2, edges 1.4 m) with h = r_s / 2 = 0.009: the voxel
  // tolerance of test_voxel_domain.cpp, 0.02 area h + 0.25 h^2 edges = 4.1e-5 m^3 (4 % of 1e-3:
  // the box is only 5.5 voxels thick).
  REQUIRE(std::abs(st.voxel_volume - 1e-3) <= 0.02 * 0.07 * 0.009 + 0.25 * 0.009 * 0.009 * 1.4);
  REQUIRE(st.volume_error == Approx((st.voxel_volume - 1e-3) / 1e-3).epsilon(1e-12));
  // Normalised: the sample volumes sum to the enclosed volume of the surface.
  REQUIRE(m.total_volume() == Approx(1e-3).epsilon(1e-12));
  REQUIRE(st.sample_volume == Approx(1e-3).epsilon(1e-12));
  REQUIRE(m.total_mass() == Approx(1000 * m.total_volume()).epsilon(1e-12));  // partition of unity
  for (int s = 0; s < m.sample_count(); ++s) REQUIRE(m.samples.volumes[s] > 0);
}

TEST_CASE("F = I at rest", "[discretise][meshless]") {
  // With frames, F = p (sum grad w)^T + sum w I at rest, so partition of unity suffices.
  const Model m = small_meshless_box().model;
  double f_error, p_error;
  affine_errors(m, identity3(), Vec3{0, 0, 0}, f_error, p_error);
  REQUIRE(f_error <= 1e-12);  // round-off: sums of 12 terms of size |grad w| |p| ~ 30 * 0.2
  REQUIRE(p_error <= kPositionTolerance);
}

TEST_CASE("meshless affine patch test: F = A and p = A p + t at every sample", "[discretise][meshless][patch]") {
  const Mat3 A = Mat3{{{1.1, 0.05, -0.02}, {0.03, 0.95, 0.04}, {-0.01, 0.02, 1.05}}};
  const Vec3 t{0.01, -0.02, 0.03};
  double f_error, p_error;
  const std::uint64_t seed = GENERATE(1, 2, 3);
  affine_errors(small_meshless_box(MaterialLaw::stvk, seed).model, A, t, f_error, p_error);
  REQUIRE(f_error <= 1e-12);
  REQUIRE(p_error <= kPositionTolerance);
}

namespace {

// Galerkin patch test of a free meshless body (no frame fixed) bounded by `boundary`, frames moved
// affinely (R = I): F = A and a constant first Piola stress P at every sample. The internal
// generalised forces (gradient of W) must equal the virtual work of the traction P N on the
// surface: translation f_i = int w_i P N dA and rotation (world-axis torque) t_i = int w_i (x -
// x_i) x (P N) dA, for boundary and interior frames alike. The surface integrals use the build's
// boundary rule (surface_quadrature at r_s), for which consistent integration makes the sample
// rule exact. Returns the largest force (N) and the largest errors of forces and torques.
struct PatchErrors {
  double scale = 0, force = 0, torque = 0;
};
PatchErrors galerkin_patch_errors(const MeshlessBuild& b, const SurfaceMesh& boundary, double rs) {
  const Model& m = b.model;
  const Mat3 A = Mat3{{{1.1, 0.05, -0.02}, {0.03, 0.95, 0.04}, {-0.01, 0.02, 1.05}}};
  State s = rest_state(m);
  for (int i = 0; i < m.frame_count(); ++i) store3(&s.positions[3 * i], A * load3(&m.frame_rest_positions[3 * i]));
  Elasticity elasticity(m, 1);
  std::vector<double> g(m.dof_count());
  elasticity.gradient(s, g.data());
  MaterialCache cache;
  const Mat3 P = first_piola(m.materials[0], A, cache);
  SurfaceQuadrature q = surface_quadrature(boundary, rs);
  if (surface_volume(boundary) < 0)
    for (double& a : q.normals) a = -a;
  const NeighbourTable t = build_meshless_table(b.shape, q.points).neighbours;
  std::vector<double> expected(m.dof_count(), 0.0);
  for (int k = 0; k < static_cast<int>(q.points.size() / 3); ++k) {
    const Vec3 traction = P * load3(&q.normals[3 * k]);
    for (int p = t.offsets[k]; p < t.offsets[k + 1]; ++p) {
      const int i = t.frames[p];
      const Vec3 f = t.weights[p] * traction, torque = cross(load3(&t.rest_offsets[3 * p]), f);
      for (int c = 0; c < 3; ++c) expected[6 * i + c] += (&f.x)[c], expected[6 * i + 3 + c] += (&torque.x)[c];
    }
  }
  PatchErrors e;
  for (int d = 0; d < m.dof_count(); ++d) {
    e.scale = std::max(e.scale, std::abs(expected[d]));
    double& error = d % 6 < 3 ? e.force : e.torque;
    error = std::max(error, std::abs(g[d] - expected[d]));
  }
  return e;
}

// An L of 10 x 5 x 3 voxels of 20 x 22 x 18 mm, sheared, less a 4 x 2 x 3 notch (a concave
// edge): label 1, in a 12 x 7 x 5 image.
LabelImage l_shaped_image() {
  LabelImage image;
  image.size = {12, 7, 5};
  image.labels.assign(static_cast<std::size_t>(image.voxel_count()), 0);
  for (int k = 1; k < 4; ++k)
    for (int j = 1; j < 6; ++j)
      for (int i = 1; i < 11; ++i)
        if (!(i >= 7 && j >= 4)) image.labels[static_cast<std::size_t>(i + 12 * (j + 7 * k))] = 1;
  image.index_to_world = Mat3{{{0.020, 0.002, 0.0}, {0.0, 0.022, 0.0}, {0.001, 0.0, 0.018}}};
  image.origin = Vec3{0.1, -0.05, 0.02};
  return image;
}

}  // namespace

TEST_CASE("meshless Galerkin patch test: a constant stress balances its boundary traction at every frame",
          "[discretise][meshless][patch]") {
  const std::uint64_t seed = GENERATE(1, 2, 3);
  const SurfaceMesh box = box_surface({0, 0, 0}, {0.2, 0.1, 0.05});
  const PatchErrors e = galerkin_patch_errors(small_meshless_box(MaterialLaw::stvk, seed), box, 0.018);
  INFO("largest force " << e.scale << " N, error " << e.force << " (translations), " << e.torque << " (rotations)");
  // Round-off of sums over ~200 samples and ~4000 surface points, through a CG solved to 1e-13:
  // 1e-10 of the largest force. Without the correction the errors are ~1e-2 of it.
  REQUIRE(e.force <= 1e-10 * e.scale);
  REQUIRE(e.torque <= 1e-10 * e.scale * 0.04);  // torques ~ force x r_f
}

TEST_CASE("a surface whose triangles face inwards: the boundary rule is turned outwards", "[discretise][meshless][patch]") {
  // surface_volume < 0: the rule's normals are negated, so the volumes fit the enclosed volume
  // and the patch test holds as for the outward box (the same tolerances). The models are not
  // identical: bisecting a triangle listed the other way round splits its equal edges in
  // another order, and the correction depends on the rule's points.
  SurfaceMesh inward = box_surface({0, 0, 0}, {0.2, 0.1, 0.05});
  for (int t = 0; t < inward.triangle_count(); ++t) std::swap(inward.triangles[3 * t + 1], inward.triangles[3 * t + 2]);
  REQUIRE(surface_volume(inward) < 0);
  MeshlessOptions options;
  options.frame_spacing = 0.04;
  options.sample_spacing = 0.018;
  const MeshlessBuild b = build_meshless_model(inward, make_material(MaterialLaw::stvk, 1.0e4, 0.3, 1000.0), options);
  REQUIRE(b.statistics.integration_defect <= 1e-11);
  REQUIRE(b.model.total_volume() == Approx(1e-3).epsilon(1e-12));
  const PatchErrors e = galerkin_patch_errors(b, inward, options.sample_spacing);
  INFO("largest force " << e.scale << " N, error " << e.force << " (translations), " << e.torque << " (rotations)");
  REQUIRE(e.force <= 1e-10 * e.scale);
  REQUIRE(e.torque <= 1e-10 * e.scale * 0.04);
}

TEST_CASE("meshless Galerkin patch test on level sets: a label image and the tissue between two boxes",
          "[discretise][meshless][patch][level_set]") {
  // The zero surface of the level set (LevelSet::surface) is the boundary rule: the same
  // tolerances as the surface-mesh box above (the same sizes: r_f 0.04 m, r_s 0.018 m).
  const Material material = make_material(MaterialLaw::stvk, 1.0e4, 0.3, 1000.0);
  MeshlessOptions options;
  options.frame_spacing = 0.04;
  options.sample_spacing = 0.018;
  options.seed = GENERATE(1, 2);
  const bool image = GENERATE(true, false);
  CAPTURE(options.seed, image);
  const double h = options.sample_spacing / 2;
  const LevelSet level_set =
      image ? LevelSet::from_labels(l_shaped_image(), {1}, h)
            : LevelSet::between(LevelSet::from_surface(box_surface({0, 0, 0}, {0.1, 0.1, 0.08}), h, 12),
                                LevelSet::from_surface(box_surface({0.15, 0, 0}, {0.25, 0.1, 0.08}), h, 12), 0.07);
  const SurfaceMesh boundary = level_set.surface();
  const MeshlessBuild b = build_meshless_model(VoxelDomain(level_set), boundary, material, options);
  const MeshlessStatistics& st = b.statistics;
  INFO(st.describe());
  REQUIRE_NOTHROW(validate(b.model));
  // Without the correction, the voxel volumes integrate the divergence identities to ~1e-2.
  REQUIRE(st.integration_defect_before > 1e-4);
  REQUIRE(st.integration_defect <= 1e-11);
  // The volumes are those the zero surface encloses (the masses change accordingly).
  REQUIRE(b.model.total_volume() == Approx(std::abs(surface_volume(boundary))).epsilon(1e-12));
  REQUIRE(st.surface_volume == Approx(std::abs(surface_volume(boundary))).epsilon(1e-12));
  REQUIRE(b.model.total_mass() == Approx(1000 * b.model.total_volume()).epsilon(1e-12));
  const PatchErrors e = galerkin_patch_errors(b, boundary, options.sample_spacing);
  INFO("largest force " << e.scale << " N, error " << e.force << " (translations), " << e.torque << " (rotations)");
  REQUIRE(e.force <= 1e-10 * e.scale);
  REQUIRE(e.torque <= 1e-10 * e.scale * 0.04);
}

TEST_CASE("the same seed builds the same model", "[discretise][meshless]") {
  const Model a = small_meshless_box(MaterialLaw::stvk, 5).model;
  const Model b = small_meshless_box(MaterialLaw::stvk, 5).model;
  const Model c = small_meshless_box(MaterialLaw::stvk, 6).model;
  REQUIRE(a.frame_rest_positions == b.frame_rest_positions);
  REQUIRE(a.samples.rest_positions == b.samples.rest_positions);
  REQUIRE(a.samples.volumes == b.samples.volumes);
  REQUIRE(a.neighbours.weights == b.neighbours.weights);
  REQUIRE(a.neighbours.weight_gradients == b.neighbours.weight_gradients);
  REQUIRE(a.frame_rest_positions != c.frame_rest_positions);
}

TEST_CASE("refining the samples keeps the frames", "[discretise][meshless]") {
  // The frames are drawn on a lattice set by r_f alone (frame_lattice_spacing): two sample
  // spacings, and an explicit voxel size of the samples' lattice, give bitwise the same frames for
  // one surface, r_f, seed and caller-placed frames (a clamp grid on x = 0, as the beam study
  // places). Ten samples per frame puts both sets on one lattice, twenty and 0.01 m do not.
  const SurfaceMesh box = box_surface({0, 0, 0}, {0.2, 0.1, 0.05});
  const Material mat = make_material(MaterialLaw::stvk, 1e4, 0.3, 1000);
  const std::uint64_t seed = GENERATE(1, 2, 3);
  MeshlessOptions options;
  options.frame_spacing = 0.04;
  options.seed = seed;
  for (double y : {0.0, 0.05, 0.1})
    for (double z : {0.0, 0.05}) options.extra_frames.insert(options.extra_frames.end(), {0.0, y, z});
  options.sample_spacing = 0.04 / std::cbrt(10.0);
  const MeshlessBuild a = build_meshless_model(box, mat, options);
  options.sample_spacing = 0.04 / std::cbrt(20.0);
  const MeshlessBuild b = build_meshless_model(box, mat, options);
  options.sample_spacing = 0.01;
  options.voxel_size = 0.004;
  const MeshlessBuild c = build_meshless_model(box, mat, options);
  INFO(a.statistics.describe() << b.statistics.describe() << c.statistics.describe());
  REQUIRE(a.statistics.voxel_size == a.statistics.frame_voxel_size);
  REQUIRE(b.statistics.voxel_size != b.statistics.frame_voxel_size);
  REQUIRE(a.statistics.added_frames == 0);
  REQUIRE(b.statistics.added_frames == 0);
  REQUIRE(c.statistics.added_frames == 0);
  REQUIRE(a.model.frame_count() >= 20);  // about 20 Poisson frames and the 6 of the grid
  REQUIRE(b.model.sample_count() > a.model.sample_count() + a.model.sample_count() / 2);
  REQUIRE(c.model.sample_count() > 2 * b.model.sample_count());
  REQUIRE(a.model.frame_rest_positions == b.model.frame_rest_positions);
  REQUIRE(a.model.frame_rest_positions == c.model.frame_rest_positions);

  // A voxelised domain (an image's or a region's) draws its frames on its boundary surface at the
  // same lattice: for a box, the frames of the surface route, whatever the domain's voxel size.
  options.sample_spacing = 0.04 / std::cbrt(20.0);
  options.voxel_size = 0;
  const MeshlessBuild d = build_meshless_model(VoxelDomain(box, 0.007), box, mat, options);
  REQUIRE(d.statistics.voxel_size == 0.007);
  REQUIRE(a.model.frame_rest_positions == d.model.frame_rest_positions);
}

TEST_CASE("thin sheets: stop names the region and radius, repair adds frames", "[discretise][meshless][thin]") {
  // A 0.6 x 0.6 m sheet 0.03 m thick, meshed with frames 0.12 m apart: one layer of frames.
  const SurfaceMesh sheet = box_surface({0, 0, 0}, {0.6, 0.6, 0.03});
  const Material mat = make_material(MaterialLaw::stvk, 1e4, 0.3, 1000);
  MeshlessOptions options;
  options.frame_spacing = 0.12;
  options.sample_spacing = 0.03;
  options.voxel_size = 0.005;
  options.thin_parts = ThinParts::stop;
  REQUIRE_THROWS_WITH(build_meshless_model(sheet, mat, options),
                      Catch::Contains("thick there") && Catch::Contains("use frame_spacing <=") &&
                          Catch::Contains("region box"));
  options.thin_parts = ThinParts::repair;
  const MeshlessBuild b = build_meshless_model(sheet, mat, options);
  INFO(b.statistics.describe());
  REQUIRE(b.statistics.added_frames > 0);
  REQUIRE(b.statistics.min_spread >= options.min_spread);
  REQUIRE_NOTHROW(validate(b.model));
  double f_error, p_error;
  affine_errors(b.model, identity3(), Vec3{0, 0, 0}, f_error, p_error);
  REQUIRE(f_error <= 1e-11);
  affine_errors(b.model, Mat3{{{1.1, 0.05, -0.02}, {0.03, 0.95, 0.04}, {-0.01, 0.02, 1.05}}}, Vec3{0, 0, 0}, f_error,
                p_error);
  REQUIRE(f_error <= 1e-11);
}

TEST_CASE("caller-placed frames (a clamped face) join the Poisson-disk frames", "[discretise][meshless]") {
  MeshlessOptions options;
  options.frame_spacing = 0.04;
  options.sample_spacing = 0.018;
  for (double y : {0.0, 0.05, 0.1})
    for (double z : {0.0, 0.05}) options.extra_frames.insert(options.extra_frames.end(), {0.0, y, z});
  const MeshlessBuild b = build_meshless_model(box_surface({0, 0, 0}, {0.2, 0.1, 0.05}),
                                               make_material(MaterialLaw::stvk, 1e4, 0.3, 1000), options);
  Model m = b.model;
  REQUIRE_NOTHROW(validate(m));
  int on_face = 0;
  for (int i = 0; i < m.frame_count(); ++i) {
    const Vec3 x = load3(&m.frame_rest_positions[3 * i]);
    if (x.x == 0.0) ++on_face;
    for (int j = 0; j < 6; ++j)  // Poisson frames keep r_f from the face frames
      if (x.x != 0.0) REQUIRE(norm(x - load3(&options.extra_frames[3 * j])) >= 0.04);
  }
  REQUIRE(on_face == 6);
  REQUIRE(fix_frames(m, [](double x, double, double) { return x == 0.0; }) == 6);
  double f_error, p_error;
  affine_errors(m, identity3(), Vec3{0, 0, 0}, f_error, p_error);
  REQUIRE(f_error <= 1e-12);
}

TEST_CASE("samples and frames are numbered along a space-filling curve", "[discretise][meshless]") {
  // Nearby points get nearby indices (a Morton curve, core/morton_order.hpp), so that the
  // per-sample and per-frame loops read nearby memory. Along the curve consecutive points lie
  // about a spacing apart, with rarer jumps between the curve's blocks: 1.8 and 1.6 spacings on
  // average here. In the order Poisson-disk sampling draws them (from a random active point each
  // time) they lie across the object: 7.7 sample spacings and 3.7 frame spacings (the box is five
  // frame spacings wide).
  MeshlessOptions options;
  options.frame_spacing = 0.02;
  options.sample_spacing = 0.006;
  const MeshlessBuild b = build_meshless_model(box_surface({0, 0, 0}, {0.2, 0.1, 0.05}),
                                               make_material(MaterialLaw::stvk, 1.0e4, 0.3, 1000.0), options);
  const auto mean_step = [](const std::vector<double>& p) {
    double sum = 0;
    const std::size_t m = p.size() / 3;
    for (std::size_t k = 1; k < m; ++k) sum += norm(load3(&p[3 * k]) - load3(&p[3 * (k - 1)]));
    return sum / static_cast<double>(m - 1);
  };
  INFO(b.statistics.describe());
  REQUIRE(b.model.sample_count() > 2000);
  const double sample_step = mean_step(b.model.samples.rest_positions);
  const double frame_step = mean_step(b.model.frame_rest_positions);
  INFO("mean steps: samples " << sample_step << " m, frames " << frame_step << " m");
  REQUIRE(sample_step < 3 * options.sample_spacing);
  REQUIRE(frame_step < 2.5 * options.frame_spacing);
}
