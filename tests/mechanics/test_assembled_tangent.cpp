// The assembled tangent (mechanics/assembled_tangent.hpp) on a model large enough for the
// parallel assembly: the same bits for any thread count, exactly symmetric, and the matrix-free
// product's values; other terms' triplets summed into the pattern as setFromTriplets sums them.
#include "mechanics/assembled_tangent.hpp"
#include "support/finite_difference.hpp"
#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

using namespace fascia;
using namespace fascia::test;

TEST_CASE("assembled tangent: the same bits for any thread count, equal to the matrix-free product", "[mechanics]") {
  // 16 x 4 x 4 hexahedra with 8 samples of 8 frames each (2,048 samples), tetrahedra (6 per cell,
  // 4 frames each: 1,536 samples), both above the one-thread limit of 256 samples. Three threads
  // own three ranges of frames: many samples have frames in two of them.
  const CellType type = GENERATE(CellType::hexahedron, CellType::tetrahedron);
  const Model model = small_box_model(type, MaterialLaw::neo_hookean, 16, 4, 4);
  REQUIRE(model.sample_count() > 256);
  const State state = random_state(model, 7, 0.004, 0.4, 1.5);
  Elasticity one(model, 1), three(model, 3);
  one.prepare(state);
  three.prepare(state);
  const Eigen::SparseMatrix<double> K1 = assemble_tangent(one), K3 = assemble_tangent(three);
  REQUIRE(K1.nonZeros() == K3.nonZeros());
  // Each entry sums its samples in sample order whatever the thread count: bitwise equal.
  Eigen::Index differing = 0;
  for (Eigen::Index k = 0; k < K1.nonZeros(); ++k) differing += K1.valuePtr()[k] != K3.valuePtr()[k];
  REQUIRE(differing == 0);
  // Block (b, a) is block (a, b) transposed, stored by the same arithmetic: K = K^T bitwise.
  const Eigen::SparseMatrix<double> K3t = K3.transpose();
  REQUIRE(K3t.nonZeros() == K3.nonZeros());
  Eigen::Index asymmetric = 0;
  for (Eigen::Index k = 0; k < K3.nonZeros(); ++k) asymmetric += K3.valuePtr()[k] != K3t.valuePtr()[k];
  REQUIRE(asymmetric == 0);
  // The assembled product equals the matrix-free one to round-off (sums of ~1e3 terms: 1e-12).
  const std::vector<double> d = random_direction(model, 5, 0.1);
  std::vector<double> kd(d.size());
  one.apply_tangent(d.data(), kd.data());
  const Eigen::VectorXd kd_assembled = K3 * Eigen::Map<const Eigen::VectorXd>(d.data(), d.size());
  double worst = 0;
  for (size_t k = 0; k < d.size(); ++k) worst = std::max(worst, std::abs(kd_assembled[k] - kd[k]));
  REQUIRE(worst <= 1e-12 * norm(kd));
}

TEST_CASE("assembled tangent: other terms' triplets are summed into the pattern, widening it where needed", "[mechanics]") {
  // The reference is K + T with T = setFromTriplets(others) (Eigen sums duplicates in their
  // order): the assembler must give the same bits, on the first call (positions located, the
  // pattern widened by the block (0, last frame), which no sample couples) and on a second with
  // the same positions and other values (positions reused).
  const Model model = small_box_model(CellType::hexahedron, MaterialLaw::neo_hookean, 3, 2, 2);
  const int n = model.frame_count(), size = 6 * n;
  Elasticity elasticity(model, 1);
  elasticity.prepare(random_state(model, 3, 0.003, 0.3, 1.2));
  const Eigen::SparseMatrix<double> K = assemble_tangent(elasticity);
  REQUIRE(std::abs(K.coeff(0, 6 * (n - 1))) == 0);  // no sample holds frames 0 and n - 1
  auto others = [&](double scale) {
    TangentAssembler::Triplets t;
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < 6; ++k) t.emplace_back(6 * i + k, 6 * i + k, scale * (1 + 0.1 * k));
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) {
        t.emplace_back(r, 6 * (n - 1) + c, scale * 0.01 * (r + 2 * c));
        t.emplace_back(6 * (n - 1) + c, r, scale * 0.01 * (r + 2 * c));
        t.emplace_back(r, 6 * (n - 1) + c, scale * 0.003);  // a duplicate
        t.emplace_back(6 * (n - 1) + c, r, scale * 0.003);
      }
    return t;
  };
  TangentAssembler assembler(model);
  for (const double scale : {1.0, -2.5}) {
    const TangentAssembler::Triplets t = others(scale);
    Eigen::SparseMatrix<double> T(size, size);
    T.setFromTriplets(t.begin(), t.end());
    const Eigen::SparseMatrix<double> reference = K + T;
    const Eigen::SparseMatrix<double>& H = assembler.assemble(elasticity, t);
    REQUIRE(H.nonZeros() == K.nonZeros() + 72);
    Eigen::Index differing = 0;
    for (int c = 0; c < size; ++c)
      for (Eigen::SparseMatrix<double>::InnerIterator it(H, c); it; ++it)
        differing += it.value() != reference.coeff(it.row(), c);
    REQUIRE(differing == 0);
    REQUIRE(std::abs(H.coeff(2, 6 * (n - 1) + 1) - scale * 0.043) <= 1e-15);
  }
}
