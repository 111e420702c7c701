#include "shape/element_shape.hpp"

#include <stdexcept>

namespace fascia {
namespace {

// grad_X N = J^{-T} grad_xi N with J = dX/dxi = sum_a X_a (grad_xi N_a)^T.
template <int K>
ElementShape<K> map_to_physical(const std::array<Vec3, K>& X, const std::array<double, K>& N,
                                const std::array<Vec3, K>& dN) {
  Mat3 J = zero3();
  for (int a = 0; a < K; ++a) J += outer(X[a], dN[a]);
  const double d = det(J);
  if (d == 0) throw std::invalid_argument("degenerate element (zero Jacobian)");
  const Mat3 j_inv_t = inverse_transpose(J);
  ElementShape<K> out;
  out.weights = N;
  for (int a = 0; a < K; ++a) out.gradients[a] = j_inv_t * dN[a];
  out.jacobian_determinant = d;
  return out;
}

}  // namespace

ElementShape<4> tet_linear_shape(const std::array<Vec3, 4>& X, const std::array<double, 3>& xi) {
  const std::array<double, 4> N{1 - xi[0] - xi[1] - xi[2], xi[0], xi[1], xi[2]};
  const std::array<Vec3, 4> dN{Vec3{-1, -1, -1}, Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, 0, 1}};
  return map_to_physical<4>(X, N, dN);
}

namespace {

void hex_reference(const std::array<double, 3>& xi, std::array<double, 8>& N, std::array<Vec3, 8>& dN) {
  static const int sign[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                 {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
  for (int a = 0; a < 8; ++a) {
    const double fx = 1 + sign[a][0] * xi[0], fy = 1 + sign[a][1] * xi[1], fz = 1 + sign[a][2] * xi[2];
    N[a] = fx * fy * fz / 8;
    dN[a] = Vec3{sign[a][0] * fy * fz / 8, sign[a][1] * fx * fz / 8, sign[a][2] * fx * fy / 8};
  }
}

}  // namespace

ElementShape<8> hex_trilinear_shape(const std::array<Vec3, 8>& X, const std::array<double, 3>& xi) {
  std::array<double, 8> N;
  std::array<Vec3, 8> dN;
  hex_reference(xi, N, dN);
  return map_to_physical<8>(X, N, dN);
}

Mat3 hex_trilinear_jacobian(const std::array<Vec3, 8>& X, const std::array<double, 3>& xi) {
  std::array<double, 8> N;
  std::array<Vec3, 8> dN;
  hex_reference(xi, N, dN);
  Mat3 J = zero3();
  for (int a = 0; a < 8; ++a) J += outer(X[a], dN[a]);
  return J;
}

}  // namespace fascia
