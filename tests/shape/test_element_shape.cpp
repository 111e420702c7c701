// Partition of unity and linear precision of the mesh-based shape functions, and sample volumes.
#include "discretise/mesh_based.hpp"
#include "shape/element_shape.hpp"
#include "shape/quadrature.hpp"

#include <catch2/catch.hpp>

using namespace fascia;

namespace {

// Distorted elements: a sheared, stretched hexahedron and a sliver-ish tetrahedron.
std::array<Vec3, 8> distorted_hex() {
  return {Vec3{0, 0, 0}, Vec3{1.2, 0.1, 0}, Vec3{1.3, 0.9, 0.1}, Vec3{-0.1, 1.0, 0},
          Vec3{0.1, 0, 0.8}, Vec3{1.1, 0.2, 1.0}, Vec3{1.2, 1.1, 0.9}, Vec3{0, 0.9, 1.1}};
}

template <int K>
void check_precision(const ElementShape<K>& sh, const std::array<Vec3, K>& X) {
  double sum_w = 0;
  Vec3 sum_g{0, 0, 0}, p{0, 0, 0};
  Mat3 xg = zero3();
  for (int a = 0; a < K; ++a) {
    sum_w += sh.weights[a];
    sum_g += sh.gradients[a];
    p += sh.weights[a] * X[a];
    xg += outer(X[a], sh.gradients[a]);
  }
  // Partition of unity and linear precision: sum w = 1, sum grad w = 0, sum x_a grad w_a^T = I.
  // Round-off only (K terms of O(1)): 1e-13.
  REQUIRE(sum_w == Approx(1.0).epsilon(1e-14));
  REQUIRE(norm(sum_g) <= 1e-13);
  REQUIRE(ddot(xg - identity3(), xg - identity3()) <= 1e-26);
}

}  // namespace

TEST_CASE("tetrahedron shape functions: partition of unity and linear precision", "[shape]") {
  const std::array<Vec3, 4> X{Vec3{0, 0, 0}, Vec3{1, 0.1, 0}, Vec3{0.2, 1, 0}, Vec3{0.3, 0.2, 0.05}};
  for (const auto& q : tet_quadrature(4)) check_precision<4>(tet_linear_shape(X, q.xi), X);
}

TEST_CASE("hexahedron shape functions: partition of unity and linear precision", "[shape]") {
  const auto X = distorted_hex();
  for (const auto& q : hex_quadrature(3)) check_precision<8>(hex_trilinear_shape(X, q.xi), X);
}

TEST_CASE("sample volumes sum to the mesh volume", "[shape][discretise]") {
  const Material m = make_material(MaterialLaw::stvk, 1e4, 0.3, 1000);
  const int q = GENERATE(1, 2, 3);
  const Model hex = build_mesh_model(box_hex_mesh({0, 0, 0}, {2, 1, 0.5}, 3, 2, 2), m, {q});
  REQUIRE(hex.total_volume() == Approx(1.0).epsilon(1e-13));
  REQUIRE(hex.sample_count() == 12 * q * q * q);
  const Model tet = build_mesh_model(box_tet_mesh({0, 0, 0}, {2, 1, 0.5}, 3, 2, 2), m, {q == 1 ? 1 : 4});
  REQUIRE(tet.total_volume() == Approx(1.0).epsilon(1e-13));
  REQUIRE(tet.total_mass() == Approx(1000.0).epsilon(1e-13));
  validate(tet);
}

TEST_CASE("degenerate elements are rejected with a message", "[shape][discretise]") {
  VolumeMesh flat = box_tet_mesh({0, 0, 0}, {1, 1, 1}, 1, 1, 1);
  for (int v = 0; v < flat.vertex_count(); ++v) flat.vertices[3 * v + 2] = 0;  // squash to a plane
  const Material m = make_material(MaterialLaw::stvk, 1e4, 0.3, 1000);
  REQUIRE_THROWS_WITH(build_mesh_model(flat, m), Catch::Contains("degenerate"));
}
