// Per-particle output fields: rigid motions carry no strain or stress and give rigid velocities;
// a homogeneous stretch gives its closed-form strain at every sample, frame and surface vertex,
// for tissues (eq. 8) and for shell membranes.
#include "io/sample_fields.hpp"
#include "io/vertex_fields.hpp"

#include "../support/fixtures.hpp"
#include "../support/shell_fixtures.hpp"
#include "io/boundary_surface.hpp"
#include "mechanics/frame_sample.hpp"

#include <catch2/catch.hpp>

#include <algorithm>

using namespace fascia;

namespace {

const Field& field(const std::vector<Field>& fields, const std::string& name) {
  for (const Field& f : fields)
    if (f.name == name) return f;
  FAIL("no field " << name);
  return fields.front();
}

double max_abs(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

// The model under x -> A x (positions only, R = I): with linear-precision shape functions F = A.
State affine_state(const Model& model, const Mat3& A) {
  State s = rest_state(model);
  for (int i = 0; i < model.frame_count(); ++i) store3(&s.positions[3 * i], A * load3(&model.frame_rest_positions[3 * i]));
  return s;
}

}  // namespace

TEST_CASE("a rigid motion has no strain or stress and a rigid velocity field", "[io]") {
  const MaterialLaw law = GENERATE(MaterialLaw::stvk, MaterialLaw::neo_hookean);
  const Model model = test::small_box_model(CellType::tetrahedron, law);
  State s = rest_state(model);
  const Vec3 r{0.3, -0.8, 0.5}, c{0.01, -0.02, 0.03}, v0{0.1, 0.2, -0.3}, omega{1.0, -2.0, 0.5};
  const Mat3 Q = rotation_matrix(quat_exp(r));
  for (int i = 0; i < model.frame_count(); ++i) {
    const Vec3 x = Q * load3(&model.frame_rest_positions[3 * i]) + c;
    store3(&s.positions[3 * i], x);
    store_quat(&s.orientations[4 * i], quat_exp(r));
    store3(&s.velocities[6 * i], v0 + cross(omega, x));
    store3(&s.velocities[6 * i + 3], omega);
  }
  std::vector<double> R;
  rotation_matrices(s, R);
  std::vector<Field> f;
  sample_fields(model, s, R, f);
  // Strains of O(1) rotations cancel to rounding (1e-15); stresses are E ~ 1e4 Pa times that.
  CHECK(max_abs(field(f, "green_strain").values) < 1e-14);
  CHECK(max_abs(field(f, "cauchy_stress").values) < 1e-9);
  CHECK(max_abs(field(f, "second_piola_von_mises").values) < 1e-9);
  CHECK(max_abs(field(f, "strain_energy_density").values) < 1e-9);
  const std::vector<double>& u = field(f, "displacement").values;
  const std::vector<double>& v = field(f, "velocity").values;
  for (int k = 0; k < model.sample_count(); ++k) {
    const Vec3 rest = load3(&model.samples.rest_positions[3 * k]), p = Q * rest + c;
    CHECK(norm(load3(&u[3 * k]) - (p - rest)) < 1e-15);
    CHECK(norm(load3(&v[3 * k]) - (v0 + cross(omega, p))) < 1e-14);
  }
  const std::vector<Field> frames = frame_fields(model, s, R);
  CHECK(norm(load3(&field(frames, "axis_y").values[0]) - Q * Vec3{0, 1, 0}) < 1e-15);
  CHECK(norm(load3(&field(frames, "angular_velocity").values[3]) - omega) == 0);
}

TEST_CASE("a homogeneous stretch gives its strain at samples, frames and surface vertices", "[io]") {
  const Model model = test::small_box_model(CellType::tetrahedron, MaterialLaw::stvk);
  const double l = 1.1;
  const Mat3 A{{{l, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  const State s = affine_state(model, A);
  std::vector<double> R;
  rotation_matrices(s, R);
  std::vector<Field> samples;
  sample_fields(model, s, R, samples);
  const StressMeasures expected = stress_measures(model.materials[0], A);
  const double e = 0.5 * (l * l - 1);
  const std::vector<double>& E = field(samples, "green_strain").values;
  for (int k = 0; k < model.sample_count(); ++k) CHECK(E[9 * k] == Approx(e).epsilon(1e-12));
  // Averages of a constant are that constant, at every frame and every surface vertex.
  const std::vector<Field> frames = frame_averages(model, samples);
  const VolumeMesh mesh = box_tet_mesh({0, 0, 0}, {0.2, 0.1, 0.05}, 2, 2, 1);
  const BoundarySurface boundary = boundary_surface(mesh);
  SurfaceLayout surface;
  surface.name = "box";
  surface.faces = boundary.faces;
  surface.vertex_frames = boundary.vertices;
  SurfaceSource source;
  source.surface = &surface;
  const std::vector<Field> vertices = surface_fields(model, s, R, source, frames);
  const std::vector<double>& sigma = field(vertices, "cauchy_stress").values;
  const std::vector<double>& u = field(vertices, "displacement").values;
  for (std::size_t v = 0; v < surface.vertex_frames.size(); ++v) {
    CHECK(sigma[9 * v] == Approx(expected.cauchy.m[0][0]).epsilon(1e-10));
    CHECK(sigma[9 * v + 4] == Approx(expected.cauchy.m[1][1]).epsilon(1e-10));
    const Vec3 rest = load3(&model.frame_rest_positions[3 * static_cast<std::size_t>(surface.vertex_frames[v])]);
    CHECK(u[3 * v] == Approx((l - 1) * rest.x).margin(1e-15));
  }
}

TEST_CASE("a stretched shell has the plane-stress membrane strain and stress", "[io]") {
  const SurfaceMesh mesh = test::rectangle_surface(0.1, 0.05, 4, 2);
  const ShellProperties p{1e-3, 1e5, 0.3, 1000};
  const Model model = test::shell_model(mesh, p);
  const double l = 1.05;
  const State s = affine_state(model, Mat3{{{l, 0, 0}, {0, 1, 0}, {0, 0, 1}}});
  const Shell& shell = model.shells[0];
  const ShellElementRest rest = make_shell_element(model.frame_rest_positions.data(), shell.triangles[0],
                                                    shell.triangles[1], shell.triangles[2], shell);
  const StressMeasures m = shell_membrane_measures(rest, shell, s.positions.data());
  const double e = 0.5 * (l * l - 1), lambda = p.young * p.poisson / (1 - p.poisson * p.poisson),
               mu = p.young / (2 * (1 + p.poisson));
  CHECK(m.green_strain.m[0][0] == Approx(e).epsilon(1e-12));
  CHECK(m.green_strain.m[1][1] == Approx(0).margin(1e-15));
  CHECK(m.second_piola.m[0][0] == Approx((lambda + 2 * mu) * e).epsilon(1e-10));
  CHECK(m.second_piola.m[1][1] == Approx(lambda * e).epsilon(1e-10));
  CHECK(m.second_piola.m[2][2] == Approx(0).margin(1e-9));  // plane stress
  // Area ratio J2 = l: sigma11 = l^2 S11 / l.
  CHECK(m.cauchy.m[0][0] == Approx(l * (lambda + 2 * mu) * e).epsilon(1e-10));
  CHECK(m.energy_density == Approx(mu * e * e + 0.5 * lambda * e * e).epsilon(1e-10));
  SurfaceLayout surface;
  surface.name = "shell";
  surface.faces = mesh.triangles;
  for (int v = 0; v < mesh.vertex_count(); ++v) surface.vertex_frames.push_back(v);
  SurfaceSource source = shell_surface_source(model, surface, shell);
  std::vector<double> R;
  rotation_matrices(s, R);
  const std::vector<Field> vertices = surface_fields(model, s, R, source, {});
  // A shell source without its rest elements is refused, not read past its end.
  SurfaceSource bare;
  bare.surface = &surface;
  bare.shell = &shell;
  CHECK_THROWS_WITH(surface_fields(model, s, R, bare, {}), Catch::Contains("shell_surface_source"));
  for (double x : field(vertices, "green_strain_principal").values) CHECK((x == Approx(e).epsilon(1e-12) || std::abs(x) < 1e-14));
  for (double x : field(vertices, "strain_energy_density").values) CHECK(x == Approx(m.energy_density).epsilon(1e-10));
}

TEST_CASE("a model with fibres writes their stretch |F a| at samples and frames", "[io][hgo]") {
  Model model = test::small_box_model(CellType::tetrahedron, MaterialLaw::neo_hookean);
  std::vector<double> R;
  rotation_matrices(rest_state(model), R);
  std::vector<Field> at_rest;
  sample_fields(model, rest_state(model), R, at_rest);
  for (const Field& f : at_rest) CHECK(f.name != "fibre_stretch");
  // Fibres along (0.6, 0.8, 0) under x -> diag(1.1, 1.2, 1) x: |F a| = |(0.66, 0.96, 0)|.
  model.materials[0] = make_hgo_material(1e4, 0.3, 1000, Fibres{5e4, 5, 0, Vec3{3, 4, 0}});
  const State s = affine_state(model, Mat3{{{1.1, 0, 0}, {0, 1.2, 0}, {0, 0, 1}}});
  rotation_matrices(s, R);
  std::vector<Field> samples;
  sample_fields(model, s, R, samples);
  const double expected = std::sqrt(0.66 * 0.66 + 0.96 * 0.96);
  // F is reproduced exactly by linear tetrahedra: rounding only.
  for (double x : field(samples, "fibre_stretch").values) CHECK(x == Approx(expected).epsilon(1e-13));
  const std::vector<Field> frames = frame_averages(model, samples);
  for (double x : field(frames, "fibre_stretch").values) CHECK(x == Approx(expected).epsilon(1e-13));
}

TEST_CASE("sample fields kept from another state are overwritten to the fields of the new one", "[io]") {
  // The output keeps its fields across rows: every value of the second state's fields must be
  // written, bitwise as a fresh evaluation gives them (an entry left from the first state fails).
  const MaterialLaw law = GENERATE(MaterialLaw::stvk, MaterialLaw::hgo);
  const Model model = test::small_box_model(CellType::tetrahedron, law);
  State a = test::random_state(model, 1, 0.002, 0.3), b = test::random_state(model, 2, 0.002, 0.3);
  for (std::size_t k = 0; k < a.velocities.size(); ++k) a.velocities[k] = 0.1 * static_cast<double>(k % 7);
  std::vector<double> Ra, Rb;
  rotation_matrices(a, Ra);
  rotation_matrices(b, Rb);
  std::vector<Field> kept, fresh;
  sample_fields(model, a, Ra, kept);
  const double* storage = kept[0].values.data();
  sample_fields(model, b, Rb, kept);
  sample_fields(model, b, Rb, fresh);
  CHECK(kept[0].values.data() == storage);  // overwritten in place
  REQUIRE(kept.size() == fresh.size());
  for (std::size_t f = 0; f < kept.size(); ++f) {
    INFO(fresh[f].name);
    CHECK(kept[f].name == fresh[f].name);
    CHECK(kept[f].values == fresh[f].values);
  }
}

TEST_CASE("averages over the frames a surface shows are those of the averages over every frame", "[io]") {
  // A surface reads the averages of its vertices' frames (mark_surface_frames): averaged over
  // those frames alone, its fields are bitwise those from averages over every frame, and the
  // frames not marked stay zero.
  const MaterialLaw law = GENERATE(MaterialLaw::stvk, MaterialLaw::hgo);
  const Model model = test::small_box_model(CellType::tetrahedron, law);
  const State s = test::random_state(model, 3, 0.002, 0.3);
  std::vector<double> R;
  rotation_matrices(s, R);
  std::vector<Field> samples;
  sample_fields(model, s, R, samples);
  SurfaceLayout surface;
  surface.name = "corner";
  surface.vertex_frames = {0, 2, 5};
  surface.faces = {0, 1, 2};
  SurfaceSource source;
  source.surface = &surface;
  std::vector<unsigned char> marked(static_cast<std::size_t>(model.frame_count()), 0);
  mark_surface_frames(source, marked);
  CHECK(std::count(marked.begin(), marked.end(), 1) == 3);
  const std::vector<Field> every = frame_averages(model, samples), some = frame_averages(model, samples, &marked);
  REQUIRE(every.size() == some.size());
  for (std::size_t f = 0; f < every.size(); ++f) {
    INFO(every[f].name);
    const std::size_t c = static_cast<std::size_t>(every[f].components);
    for (std::size_t i = 0; i < marked.size(); ++i)
      for (std::size_t j = 0; j < c; ++j)
        CHECK(some[f].values[c * i + j] == (marked[i] ? every[f].values[c * i + j] : 0.0));
  }
  const std::vector<Field> a = surface_fields(model, s, R, source, every);
  const std::vector<Field> b = surface_fields(model, s, R, source, some);
  REQUIRE(a.size() == b.size());
  for (std::size_t f = 0; f < a.size(); ++f) CHECK(a[f].values == b[f].values);
  // A shell's surface takes its measures from the shell: no frame is marked for it.
  Shell shell;
  source.shell = &shell;
  std::vector<unsigned char> none(marked.size(), 0);
  mark_surface_frames(source, none);
  CHECK(std::count(none.begin(), none.end(), 1) == 0);
}

TEST_CASE("sample fields give the samples' positions of eq. (3) and their displacements", "[io]") {
  const Model model = test::small_box_model(CellType::tetrahedron, MaterialLaw::neo_hookean);
  const State s = test::random_state(model, 4, 0.002, 0.3);
  std::vector<double> R;
  rotation_matrices(s, R);
  std::vector<Field> fields;
  std::vector<double> positions;
  sample_fields(model, s, R, fields, &positions);
  REQUIRE(positions.size() == 3 * static_cast<std::size_t>(model.sample_count()));
  const NeighbourTable& t = model.neighbours;
  const PairTableView view{t.offsets.data(), t.frames.data(), t.weights.data(), t.weight_gradients.data(),
                           t.rest_offsets.data()};
  const std::vector<double>& u = field(fields, "displacement").values;
  for (int k = 0; k < model.sample_count(); ++k) {
    const std::size_t at = 3 * static_cast<std::size_t>(k);
    const Vec3 p = sample_position(view, k, s.positions.data(), R.data());
    // The same sums in the same order: bitwise.
    CHECK(positions[at] == p.x);
    CHECK(positions[at + 1] == p.y);
    CHECK(positions[at + 2] == p.z);
    CHECK(u[at] == p.x - model.samples.rest_positions[at]);
  }
  // F as sample_deformation_gradient gives it: the Green strain of the fields, bitwise.
  const std::vector<double>& E = field(fields, "green_strain").values;
  for (int k = 0; k < model.sample_count(); ++k) {
    const std::size_t sk = static_cast<std::size_t>(k);
    const Material& material = model.materials[static_cast<std::size_t>(model.samples.materials[sk])];
    const StressMeasures m =
        stress_measures(material, sample_deformation_gradient(view, k, s.positions.data(), R.data()));
    for (std::size_t e = 0; e < 9; ++e) CHECK(E[9 * sk + e] == m.green_strain.m[e / 3][e % 3]);
  }
}
