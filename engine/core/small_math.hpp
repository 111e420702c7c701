// Fixed-size 3-vectors and 3x3 matrices for the per-sample mechanics.
//
// Plain aggregates with FASCIA_HD functions so that the same code runs in the CPU reference
// (engine/) and in the CUDA kernels (kernels/). Eigen is used for everything global (sparse
// tangents, solvers); these types stay in registers.
//
// The scalar type is a template parameter: Vec3 and Mat3 (double) are what the engine uses; the
// CUDA kernels also instantiate the same code in float for the single-precision tangent product
// (kernels/elasticity_phases.hpp). Scalar factors are taken as `Scalar<T>` (not deduced), so
// `2 * a` or `w * R` with a double w work for either type.
#pragma once

#include "core/config.hpp"

#include <cmath>

namespace fascia {

template <class T>
struct ScalarOf {
  using type = T;
};
// A scalar argument of type T that does not take part in template argument deduction.
template <class T>
using Scalar = typename ScalarOf<T>::type;

template <class T>
struct Vec3T {
  T x, y, z;
};

// Row-major 3x3 matrix: m[r][c].
template <class T>
struct Mat3T {
  T m[3][3];
};

using Vec3 = Vec3T<double>;
using Mat3 = Mat3T<double>;

FASCIA_HD Vec3 vec3(double x, double y, double z) { return Vec3{x, y, z}; }
// A 3-vector from p[0..2], and back (T: double, float, or a lane type).
template <class T>
FASCIA_HD Vec3T<T> load3(const T* p) {
  return Vec3T<T>{p[0], p[1], p[2]};
}
template <class T>
FASCIA_HD void store3(T* p, const Vec3T<T>& v) {
  p[0] = v.x;
  p[1] = v.y;
  p[2] = v.z;
}
template <class T>
FASCIA_HD Vec3T<T> operator+(const Vec3T<T>& a, const Vec3T<T>& b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
template <class T>
FASCIA_HD Vec3T<T> operator-(const Vec3T<T>& a, const Vec3T<T>& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <class T>
FASCIA_HD Vec3T<T> operator-(const Vec3T<T>& a) {
  return {-a.x, -a.y, -a.z};
}
template <class T>
FASCIA_HD Vec3T<T> operator*(Scalar<T> s, const Vec3T<T>& a) {
  return {s * a.x, s * a.y, s * a.z};
}
template <class T>
FASCIA_HD Vec3T<T>& operator+=(Vec3T<T>& a, const Vec3T<T>& b) {
  a.x += b.x;
  a.y += b.y;
  a.z += b.z;
  return a;
}
template <class T>
FASCIA_HD T dot(const Vec3T<T>& a, const Vec3T<T>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <class T>
FASCIA_HD Vec3T<T> cross(const Vec3T<T>& a, const Vec3T<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T>
FASCIA_HD T norm(const Vec3T<T>& a) {
  using std::sqrt;  // and a lane type's own sqrt (core/double_lanes.hpp)
  return sqrt(dot(a, a));
}

template <class T = double>
FASCIA_HD Mat3T<T> zero3() {
  return Mat3T<T>{{{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}};
}
template <class T = double>
FASCIA_HD Mat3T<T> identity3() {
  return Mat3T<T>{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
}
FASCIA_HD Mat3 load_mat3(const double* p) {
  return Mat3{{{p[0], p[1], p[2]}, {p[3], p[4], p[5]}, {p[6], p[7], p[8]}}};
}
FASCIA_HD void store_mat3(double* p, const Mat3& a) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) p[3 * r + c] = a.m[r][c];
}
template <class T>
FASCIA_HD Mat3T<T> operator+(const Mat3T<T>& a, const Mat3T<T>& b) {
  Mat3T<T> c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c.m[i][j] = a.m[i][j] + b.m[i][j];
  return c;
}
template <class T>
FASCIA_HD Mat3T<T> operator-(const Mat3T<T>& a, const Mat3T<T>& b) {
  Mat3T<T> c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c.m[i][j] = a.m[i][j] - b.m[i][j];
  return c;
}
template <class T>
FASCIA_HD Mat3T<T> operator*(Scalar<T> s, const Mat3T<T>& a) {
  Mat3T<T> c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c.m[i][j] = s * a.m[i][j];
  return c;
}
template <class T>
FASCIA_HD Mat3T<T>& operator+=(Mat3T<T>& a, const Mat3T<T>& b) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a.m[i][j] += b.m[i][j];
  return a;
}
template <class T>
FASCIA_HD Mat3T<T> operator*(const Mat3T<T>& a, const Mat3T<T>& b) {
  Mat3T<T> c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      c.m[i][j] = a.m[i][0] * b.m[0][j] + a.m[i][1] * b.m[1][j] + a.m[i][2] * b.m[2][j];
  return c;
}
template <class T>
FASCIA_HD Vec3T<T> operator*(const Mat3T<T>& a, const Vec3T<T>& v) {
  return {a.m[0][0] * v.x + a.m[0][1] * v.y + a.m[0][2] * v.z,
          a.m[1][0] * v.x + a.m[1][1] * v.y + a.m[1][2] * v.z,
          a.m[2][0] * v.x + a.m[2][1] * v.y + a.m[2][2] * v.z};
}
template <class T>
FASCIA_HD Mat3T<T> transpose(const Mat3T<T>& a) {
  Mat3T<T> c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c.m[i][j] = a.m[j][i];
  return c;
}
template <class T>
FASCIA_HD T trace(const Mat3T<T>& a) {
  return a.m[0][0] + a.m[1][1] + a.m[2][2];
}
// Frobenius inner product A : B.
template <class T>
FASCIA_HD T ddot(const Mat3T<T>& a, const Mat3T<T>& b) {
  T s = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) s += a.m[i][j] * b.m[i][j];
  return s;
}
template <class T>
FASCIA_HD T det(const Mat3T<T>& a) {
  return a.m[0][0] * (a.m[1][1] * a.m[2][2] - a.m[1][2] * a.m[2][1]) -
         a.m[0][1] * (a.m[1][0] * a.m[2][2] - a.m[1][2] * a.m[2][0]) +
         a.m[0][2] * (a.m[1][0] * a.m[2][1] - a.m[1][1] * a.m[2][0]);
}
// Inverse transpose F^{-T}; precondition det(a) != 0.
template <class T>
FASCIA_HD Mat3T<T> inverse_transpose(const Mat3T<T>& a) {
  const T inv = T(1) / det(a);
  Mat3T<T> c;  // cofactor matrix / det
  c.m[0][0] = (a.m[1][1] * a.m[2][2] - a.m[1][2] * a.m[2][1]) * inv;
  c.m[0][1] = (a.m[1][2] * a.m[2][0] - a.m[1][0] * a.m[2][2]) * inv;
  c.m[0][2] = (a.m[1][0] * a.m[2][1] - a.m[1][1] * a.m[2][0]) * inv;
  c.m[1][0] = (a.m[0][2] * a.m[2][1] - a.m[0][1] * a.m[2][2]) * inv;
  c.m[1][1] = (a.m[0][0] * a.m[2][2] - a.m[0][2] * a.m[2][0]) * inv;
  c.m[1][2] = (a.m[0][1] * a.m[2][0] - a.m[0][0] * a.m[2][1]) * inv;
  c.m[2][0] = (a.m[0][1] * a.m[1][2] - a.m[0][2] * a.m[1][1]) * inv;
  c.m[2][1] = (a.m[0][2] * a.m[1][0] - a.m[0][0] * a.m[1][2]) * inv;
  c.m[2][2] = (a.m[0][0] * a.m[1][1] - a.m[0][1] * a.m[1][0]) * inv;
  return c;
}
// Outer product a b^T.
template <class T>
FASCIA_HD Mat3T<T> outer(const Vec3T<T>& a, const Vec3T<T>& b) {
  return Mat3T<T>{{{a.x * b.x, a.x * b.y, a.x * b.z},
                   {a.y * b.x, a.y * b.y, a.y * b.z},
                   {a.z * b.x, a.z * b.y, a.z * b.z}}};
}
// Cross-product matrix [v]x such that [v]x a = v x a.
template <class T>
FASCIA_HD Mat3T<T> skew(const Vec3T<T>& v) {
  return Mat3T<T>{{{0, -v.z, v.y}, {v.z, 0, -v.x}, {-v.y, v.x, 0}}};
}
// Axial vector of the skew part: axial(A) = (A23 - A32, A31 - A13, A12 - A21), so that
// tr([v]x A) = v . axial(A) for every v.
template <class T>
FASCIA_HD Vec3T<T> axial(const Mat3T<T>& a) {
  return {a.m[1][2] - a.m[2][1], a.m[2][0] - a.m[0][2], a.m[0][1] - a.m[1][0]};
}
template <class T>
FASCIA_HD Mat3T<T> symmetric_part(const Mat3T<T>& a) {
  return T(0.5) * (a + transpose(a));
}

// [v]x A without the zero entries of [v]x: 18 multiplies instead of 27.
template <class T>
FASCIA_HD Mat3T<T> skew_times(const Vec3T<T>& v, const Mat3T<T>& a) {
  Mat3T<T> c;
  for (int j = 0; j < 3; ++j) {
    c.m[0][j] = v.y * a.m[2][j] - v.z * a.m[1][j];
    c.m[1][j] = v.z * a.m[0][j] - v.x * a.m[2][j];
    c.m[2][j] = v.x * a.m[1][j] - v.y * a.m[0][j];
  }
  return c;
}
// axial(A B^T) from the rows of A and B: only the three antisymmetric combinations, 18 multiplies
// instead of the 27 of the full product.
template <class T>
FASCIA_HD Vec3T<T> axial_times_transpose(const Mat3T<T>& a, const Mat3T<T>& b) {
  Vec3T<T> r{0, 0, 0};
  for (int j = 0; j < 3; ++j) {
    r.x += a.m[1][j] * b.m[2][j] - a.m[2][j] * b.m[1][j];
    r.y += a.m[2][j] * b.m[0][j] - a.m[0][j] * b.m[2][j];
    r.z += a.m[0][j] * b.m[1][j] - a.m[1][j] * b.m[0][j];
  }
  return r;
}

}  // namespace fascia
