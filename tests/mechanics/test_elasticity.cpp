// Finite-difference checks of the elastic energy, forces (eq. 18) and tangent (eq. 20-28).
#include "mechanics/assembled_tangent.hpp"
#include "mechanics/elasticity.hpp"
#include "support/finite_difference.hpp"
#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

using namespace fascia;
using namespace fascia::test;

namespace {

struct Case {
  CellType type;
  MaterialLaw law;
  double displacement, rotation, global_rotation;
};

}  // namespace

TEST_CASE("elastic forces are minus the gradient of the re-parametrised energy", "[mechanics][fd]") {
  const Case c = GENERATE(Case{CellType::hexahedron, MaterialLaw::stvk, 0.01, 0.3, 0.0},
                          Case{CellType::hexahedron, MaterialLaw::stvk, 0.02, 1.0, 2.5},
                          Case{CellType::tetrahedron, MaterialLaw::stvk, 0.02, 1.0, 2.5},
                          Case{CellType::hexahedron, MaterialLaw::neo_hookean, 0.005, 0.2, 2.5},
                          Case{CellType::tetrahedron, MaterialLaw::neo_hookean, 0.005, 0.2, 1.0});
  const Model model = small_box_model(c.type, c.law);
  const State state = random_state(model, 7, c.displacement, c.rotation, c.global_rotation);
  Elasticity elasticity(model);
  std::vector<double> g(model.dof_count());
  const double w = elasticity.gradient(state, g.data());
  REQUIRE(w == Approx(elasticity.energy(state)).epsilon(1e-14));
  REQUIRE(std::isfinite(w));
  const Energy energy = [&](const State& s) { return elasticity.energy(s); };
  const double scale = norm(g);
  for (int k = 0; k < model.dof_count(); ++k) {
    std::vector<double> e(model.dof_count(), 0.0);
    e[k] = 1.0;
    const double fd = directional_derivative(model, energy, state, e);
    INFO("dof " << k << " fd " << fd << " analytic " << g[k]);
    REQUIRE(std::abs(fd - g[k]) <= 1e-6 * scale);
  }
}

TEST_CASE("tangent product is the Hessian of the re-parametrised energy", "[mechanics][fd]") {
  const Case c = GENERATE(Case{CellType::hexahedron, MaterialLaw::stvk, 0.02, 1.0, 2.5},
                          Case{CellType::tetrahedron, MaterialLaw::stvk, 0.02, 1.0, 2.5},
                          Case{CellType::hexahedron, MaterialLaw::neo_hookean, 0.005, 0.3, 2.5});
  const Model model = small_box_model(c.type, c.law);
  const State state = random_state(model, 11, c.displacement, c.rotation, c.global_rotation);
  Elasticity elasticity(model);
  elasticity.prepare(state);
  const Energy energy = [&](const State& s) { return elasticity.energy(s); };
  for (unsigned seed = 1; seed <= 3; ++seed) {
    const std::vector<double> d = random_direction(model, seed, 0.1);
    std::vector<double> kd(model.dof_count());
    elasticity.apply_tangent(d.data(), kd.data());
    const double scale = norm(kd);
    for (int k = 0; k < model.dof_count(); ++k) {
      std::vector<double> e(model.dof_count(), 0.0);
      e[k] = k % 6 < 3 ? 0.1 : 1.0;  // same length scale as d
      const double fd = mixed_second_derivative(model, energy, state, d, e);
      INFO("seed " << seed << " dof " << k << " fd " << fd << " analytic " << kd[k] * e[k]);
      REQUIRE(std::abs(fd - kd[k] * e[k]) <= 1e-5 * scale);
    }
  }
}

TEST_CASE("tangent is symmetric and equals its assembled form and diagonal blocks", "[mechanics]") {
  const MaterialLaw law = GENERATE(MaterialLaw::stvk, MaterialLaw::neo_hookean);
  const CellType type = GENERATE(CellType::hexahedron, CellType::tetrahedron);
  const Model model = small_box_model(type, law, 3, 2, 2);
  const State state = random_state(model, 3, 0.004, 0.4, 1.5);
  Elasticity elasticity(model);
  elasticity.prepare(state);
  const Eigen::SparseMatrix<double> K = assemble_tangent(elasticity);
  const std::vector<double> d = random_direction(model, 5, 0.1), e = random_direction(model, 6, 0.1);
  std::vector<double> kd(d.size()), ke(d.size());
  elasticity.apply_tangent(d.data(), kd.data());
  elasticity.apply_tangent(e.data(), ke.data());
  const double scale = norm(kd) * norm(e);
  // Symmetry of the matrix-free operator; round-off only (sums of ~1e3 terms): 1e-12.
  REQUIRE(std::abs(dot(e, kd) - dot(d, ke)) <= 1e-12 * scale);
  // Assembled and matrix-free agree to round-off.
  const Eigen::Map<const Eigen::VectorXd> dv(d.data(), d.size());
  const Eigen::VectorXd kd_assembled = K * dv;
  for (size_t k = 0; k < d.size(); ++k) REQUIRE(std::abs(kd_assembled[k] - kd[k]) <= 1e-12 * norm(kd));
  REQUIRE((Eigen::MatrixXd(K) - Eigen::MatrixXd(K).transpose()).cwiseAbs().maxCoeff() <=
          1e-12 * Eigen::MatrixXd(K).cwiseAbs().maxCoeff());
  std::vector<double> blocks(36 * model.frame_count());
  elasticity.tangent_diagonal_blocks(blocks.data());
  const Eigen::MatrixXd dense(K);
  for (int i = 0; i < model.frame_count(); ++i)
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c)
        REQUIRE(std::abs(blocks[36 * i + 6 * r + c] - dense(6 * i + r, 6 * i + c)) <= 1e-12 * dense.cwiseAbs().maxCoeff());
}

TEST_CASE("translation block of the tangent is the derivative of the forces", "[mechanics][fd]") {
  const Model model = small_box_model(CellType::hexahedron, MaterialLaw::stvk);
  const State state = random_state(model, 13, 0.02, 1.0, 2.0);
  Elasticity elasticity(model);
  elasticity.prepare(state);
  std::vector<double> d = random_direction(model, 9, 0.1);
  for (int i = 0; i < model.frame_count(); ++i)
    for (int k = 3; k < 6; ++k) d[6 * i + k] = 0;  // translations compose additively
  std::vector<double> kd(d.size()), gp(d.size()), gm(d.size());
  elasticity.apply_tangent(d.data(), kd.data());
  const double h = 6e-6;  // cbrt(eps), see finite_difference.hpp
  elasticity.gradient(perturbed(model, state, d, h), gp.data());
  elasticity.gradient(perturbed(model, state, d, -h), gm.data());
  for (size_t k = 0; k < d.size(); ++k) {
    // The rotational rows of dg/dt differ from K d by the skew part (DESIGN.md): the gradient at
    // q + t dx is taken w.r.t. increments around q + t dx, which for translations is the same.
    const double fd = (gp[k] - gm[k]) / (2 * h);
    REQUIRE(std::abs(fd - kd[k]) <= 1e-6 * norm(kd));
  }
}

TEST_CASE("SIMD tangent product matches the per-pair formulas, any thread count, mixed laws", "[mechanics]") {
  // 9 x 5 x 5 cells of 6 tetrahedra: 1350 samples, above the serial threshold (1024) and not a
  // multiple of the lane count, so the last block has empty lanes. The first third of the samples
  // is neo-Hookean, and every third sample of the second third: blocks of one law take that law's
  // lane code (StVK, neo-Hookean), blocks that mix laws the generic material path.
  Model model = small_box_model(CellType::tetrahedron, MaterialLaw::stvk, 9, 5, 5);
  model.materials.push_back(make_material(MaterialLaw::neo_hookean, 2.0e4, 0.35, 1000.0));
  const int third = model.sample_count() / 3;
  for (int s = 0; s < 2 * third; ++s)
    if (s < third || s % 3 == 0) model.samples.materials[s] = 1;
  const State state = random_state(model, 21, 0.001, 0.3, 0.7);
  const std::vector<double> d = random_direction(model, 8, 0.1);
  std::vector<double> extra(10 * model.frame_count());
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (double& e : extra) e = u(rng);

  Elasticity one(model, 1), two(model, 2);
  one.prepare(state);
  two.prepare(state);
  std::vector<double> kd1(d.size()), kd2(d.size()), kde(d.size());
  one.apply_tangent(d.data(), kd1.data());
  two.apply_tangent(d.data(), kd2.data());
  two.apply_tangent(d.data(), kde.data(), extra.data());
  for (size_t k = 0; k < d.size(); ++k) REQUIRE(kd1[k] == kd2[k]);  // bitwise: fixed summation order

  // Reference: the unfactored pair formulas of frame_sample.hpp (eq. 11, 21-26), sample by sample.
  const NeighbourTable& nb = model.neighbours;
  std::vector<double> rot;
  rotation_matrices(state, rot);
  std::vector<double> ref(d.size(), 0.0);
  for (int s = 0; s < model.sample_count(); ++s) {
    PairTableView view{nb.offsets.data(), nb.frames.data(), nb.weights.data(), nb.weight_gradients.data(),
                       nb.rest_offsets.data()};
    const Mat3 F = sample_deformation_gradient(view, s, state.positions.data(), rot.data());
    Mat3 dF = zero3();
    for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) {
      const int i = nb.frames[p];
      const Mat3 R = load_mat3(&rot[9 * i]);
      dF += pair_deformation_differential(load3(&d[6 * i]), load3(&d[6 * i + 3]), R * load3(&nb.rest_offsets[3 * p]),
                                          load3(&nb.weight_gradients[3 * p]), nb.weights[p], R);
    }
    const Material& mat = model.materials[model.samples.materials[s]];
    MaterialCache cache;
    first_piola(mat, F, cache);
    const Mat3 dP = pk1_differential(mat, F, cache, dF);
    for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) {
      const int i = nb.frames[p];
      const Mat3 R = load_mat3(&rot[9 * i]);
      double share[6];
      pair_virtual_work(dP, R * load3(&nb.rest_offsets[3 * p]), load3(&nb.weight_gradients[3 * p]), nb.weights[p], R,
                        model.samples.volumes[s], share);
      for (int j = 0; j < 6; ++j) ref[6 * i + j] += share[j];
    }
  }
  const std::vector<double>& G = one.rotational_blocks();
  for (int i = 0; i < model.frame_count(); ++i) {
    const Vec3 r = load_mat3(&G[9 * i]) * load3(&d[6 * i + 3]);
    ref[6 * i + 3] += r.x, ref[6 * i + 4] += r.y, ref[6 * i + 5] += r.z;
  }
  // Round-off only (the factored formulas sum the same terms in another order): 1e-12.
  const double scale = norm(ref);
  for (size_t k = 0; k < d.size(); ++k) REQUIRE(std::abs(kd1[k] - ref[k]) <= 1e-12 * scale);
  // The frame diagonal adds diag(t_i I3, Q_i) d_i.
  for (int i = 0; i < model.frame_count(); ++i) {
    const double* e = &extra[10 * i];
    for (int r = 0; r < 3; ++r) {
      REQUIRE(std::abs(kde[6 * i + r] - (kd1[6 * i + r] + e[0] * d[6 * i + r])) <= 1e-12 * scale);
      const double q = e[1 + 3 * r] * d[6 * i + 3] + e[2 + 3 * r] * d[6 * i + 4] + e[3 + 3 * r] * d[6 * i + 5];
      REQUIRE(std::abs(kde[6 * i + 3 + r] - (kd1[6 * i + 3 + r] + q)) <= 1e-12 * scale);
    }
  }
}
