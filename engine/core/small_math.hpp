// Fixed-size 3-vectors and 3x3 matrices for the per-sample mechanics.
//
// Plain aggregates with FASCIA_HD functions so that the same code runs in the CPU reference
// (engine/) and in the CUDA kernels (kernels/). Eigen is used for everything global (sparse
// tangents, solvers); these types stay in registers.
#pragma once

#include "core/config.hpp"

#include <cmath>

namespace fascia {

struct Vec3 {
  double x, y, z;
};

// Row-major 3x3 matrix: m[r][c].
struct Mat3 {
  double m[3][3];
};

FASCIA_HD Vec3 vec3(double x, double y, double z) { return Vec3{x, y, z}; }
FASCIA_HD Vec3 load3(const double* p) { return Vec3{p[0], p[1], p[2]}; }
FASCIA_HD void store3(double* p, const Vec3& v) {
  p[0] = v.x;
  p[1] = v.y;
  p[2] = v.z;
}
FASCIA_HD Vec3 operator+(const Vec3& a, const Vec3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
FASCIA_HD Vec3 operator-(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
FASCIA_HD Vec3 operator-(const Vec3& a) { return {-a.x, -a.y, -a.z}; }
FASCIA_HD Vec3 operator*(double s, const Vec3& a) { return {s * a.x, s * a.y, s * a.z}; }
FASCIA_HD Vec3& operator+=(Vec3& a, const Vec3& b) {
  a.x += b.x;
  a.y += b.y;
  a.z += b.z;
  return a;
}
FASCIA_HD double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
FASCIA_HD Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
FASCIA_HD double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }

FASCIA_HD Mat3 zero3() { return Mat3{{{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}}; }
FASCIA_HD Mat3 identity3() { return Mat3{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}}; }
FASCIA_HD Mat3 load_mat3(const double* p) {
  return Mat3{{{p[0], p[1], p[2]}, {p[3], p[4], p[5]}, {p[6], p[7], p[8]}}};
}
FASCIA_HD void store_mat3(double* p, const Mat3& a) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) p[3 * r + c] = a.m[r][c];
}
FASCIA_HD Mat3 operator+(const Mat3& a, const Mat3& b) {
  Mat3 c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c.m[i][j] = a.m[i][j] + b.m[i][j];
  return c;
}
FASCIA_HD Mat3 operator-(const Mat3& a, const Mat3& b) {
  Mat3 c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c.m[i][j] = a.m[i][j] - b.m[i][j];
  return c;
}
FASCIA_HD Mat3 operator*(double s, const Mat3& a) {
  Mat3 c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c.m[i][j] = s * a.m[i][j];
  return c;
}
FASCIA_HD Mat3& operator+=(Mat3& a, const Mat3& b) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a.m[i][j] += b.m[i][j];
  return a;
}
FASCIA_HD Mat3 operator*(const Mat3& a, const Mat3& b) {
  Mat3 c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      c.m[i][j] = a.m[i][0] * b.m[0][j] + a.m[i][1] * b.m[1][j] + a.m[i][2] * b.m[2][j];
  return c;
}
FASCIA_HD Vec3 operator*(const Mat3& a, const Vec3& v) {
  return {a.m[0][0] * v.x + a.m[0][1] * v.y + a.m[0][2] * v.z,
          a.m[1][0] * v.x + a.m[1][1] * v.y + a.m[1][2] * v.z,
          a.m[2][0] * v.x + a.m[2][1] * v.y + a.m[2][2] * v.z};
}
FASCIA_HD Mat3 transpose(const Mat3& a) {
  Mat3 c;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c.m[i][j] = a.m[j][i];
  return c;
}
FASCIA_HD double trace(const Mat3& a) { return a.m[0][0] + a.m[1][1] + a.m[2][2]; }
// Frobenius inner product A : B.
FASCIA_HD double ddot(const Mat3& a, const Mat3& b) {
  double s = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) s += a.m[i][j] * b.m[i][j];
  return s;
}
FASCIA_HD double det(const Mat3& a) {
  return a.m[0][0] * (a.m[1][1] * a.m[2][2] - a.m[1][2] * a.m[2][1]) -
         a.m[0][1] * (a.m[1][0] * a.m[2][2] - a.m[1][2] * a.m[2][0]) +
         a.m[0][2] * (a.m[1][0] * a.m[2][1] - a.m[1][1] * a.m[2][0]);
}
// Inverse transpose F^{-T}; precondition det(a) != 0.
FASCIA_HD Mat3 inverse_transpose(const Mat3& a) {
  const double inv = 1.0 / det(a);
  Mat3 c;  // cofactor matrix / det
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
FASCIA_HD Mat3 outer(const Vec3& a, const Vec3& b) {
  return Mat3{{{a.x * b.x, a.x * b.y, a.x * b.z},
               {a.y * b.x, a.y * b.y, a.y * b.z},
               {a.z * b.x, a.z * b.y, a.z * b.z}}};
}
// Cross-product matrix [v]x such that [v]x a = v x a.
FASCIA_HD Mat3 skew(const Vec3& v) {
  return Mat3{{{0, -v.z, v.y}, {v.z, 0, -v.x}, {-v.y, v.x, 0}}};
}
// Axial vector of the skew part: axial(A) = (A23 - A32, A31 - A13, A12 - A21), so that
// tr([v]x A) = v . axial(A) for every v.
FASCIA_HD Vec3 axial(const Mat3& a) {
  return {a.m[1][2] - a.m[2][1], a.m[2][0] - a.m[0][2], a.m[0][1] - a.m[1][0]};
}
FASCIA_HD Mat3 symmetric_part(const Mat3& a) { return 0.5 * (a + transpose(a)); }

// [v]x A without the zero entries of [v]x: 18 multiplies instead of 27.
FASCIA_HD Mat3 skew_times(const Vec3& v, const Mat3& a) {
  Mat3 c;
  for (int j = 0; j < 3; ++j) {
    c.m[0][j] = v.y * a.m[2][j] - v.z * a.m[1][j];
    c.m[1][j] = v.z * a.m[0][j] - v.x * a.m[2][j];
    c.m[2][j] = v.x * a.m[1][j] - v.y * a.m[0][j];
  }
  return c;
}
// axial(A B^T) from the rows of A and B: only the three antisymmetric combinations, 18 multiplies
// instead of the 27 of the full product.
FASCIA_HD Vec3 axial_times_transpose(const Mat3& a, const Mat3& b) {
  Vec3 r{0, 0, 0};
  for (int j = 0; j < 3; ++j) {
    r.x += a.m[1][j] * b.m[2][j] - a.m[2][j] * b.m[1][j];
    r.y += a.m[2][j] * b.m[0][j] - a.m[0][j] * b.m[2][j];
    r.z += a.m[0][j] * b.m[1][j] - a.m[1][j] * b.m[0][j];
  }
  return r;
}

}  // namespace fascia
