// Unit quaternions for frame orientations.
//
// Convention (DESIGN.md): q = (w, x, y, z), R(q) rotates frame-local vectors to world axes, and
// an increment dr (world axes, radians) updates R <- exp([dr]x) R, i.e. q <- exp_quat(dr) * q,
// followed by renormalisation.
#pragma once

#include "core/small_math.hpp"

namespace fascia {

struct Quat {
  double w, x, y, z;
};

FASCIA_HD Quat load_quat(const double* p) { return Quat{p[0], p[1], p[2], p[3]}; }
FASCIA_HD void store_quat(double* p, const Quat& q) {
  p[0] = q.w;
  p[1] = q.x;
  p[2] = q.y;
  p[3] = q.z;
}

FASCIA_HD Quat operator*(const Quat& a, const Quat& b) {
  return Quat{a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
              a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
              a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
              a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}

FASCIA_HD Quat normalized(const Quat& q) {
  const double n = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
  return Quat{q.w / n, q.x / n, q.y / n, q.z / n};
}

// Quaternion of the rotation exp([v]x): angle |v| about v/|v|. Uses the Taylor series of
// sin(t/2)/t below t = 1e-4 where the quotient loses digits (error < t^4/3840 ~ 3e-20).
FASCIA_HD Quat quat_exp(const Vec3& v) {
  const double t = norm(v);
  const double half = 0.5 * t;
  const double s = t < 1e-4 ? 0.5 - t * t / 48.0 : std::sin(half) / t;
  return Quat{std::cos(half), s * v.x, s * v.y, s * v.z};
}

// Rotation vector of q (inverse of quat_exp), angle in [0, pi].
FASCIA_HD Vec3 quat_log(const Quat& q_in) {
  Quat q = q_in.w < 0 ? Quat{-q_in.w, -q_in.x, -q_in.y, -q_in.z} : q_in;
  const double s = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
  const double angle = 2.0 * std::atan2(s, q.w);
  const double k = s < 1e-12 ? 2.0 / q.w : angle / s;
  return Vec3{k * q.x, k * q.y, k * q.z};
}

FASCIA_HD Quat conjugate(const Quat& q) { return Quat{q.w, -q.x, -q.y, -q.z}; }

// Rotation matrix R(q) of a unit quaternion.
FASCIA_HD Mat3 rotation_matrix(const Quat& q) {
  const double xx = q.x * q.x, yy = q.y * q.y, zz = q.z * q.z;
  const double xy = q.x * q.y, xz = q.x * q.z, yz = q.y * q.z;
  const double wx = q.w * q.x, wy = q.w * q.y, wz = q.w * q.z;
  return Mat3{{{1 - 2 * (yy + zz), 2 * (xy - wz), 2 * (xz + wy)},
               {2 * (xy + wz), 1 - 2 * (xx + zz), 2 * (yz - wx)},
               {2 * (xz - wy), 2 * (yz + wx), 1 - 2 * (xx + yy)}}};
}

// Applies a world-axis increment: q <- normalise(exp(dr) q).
FASCIA_HD Quat apply_increment(const Quat& q, const Vec3& dr) { return normalized(quat_exp(dr) * q); }

}  // namespace fascia
