// Generic finite-difference harness for energy / gradient / Hessian-product triples on the frame
// configuration space, always re-parametrised around the base point: phi(theta) = E(q (+) theta).
//
// Step sizes (double precision, eps = 2.2e-16):
//  * gradient, central difference: truncation ~ h^2 |phi'''| / 6, round-off ~ eps |phi| / h;
//    the sum is smallest at h ~ cbrt(eps) ~ 6e-6 (in units of the state's length scale), giving
//    a relative error ~ eps^(2/3) ~ 4e-11 times the problem's scale factors.
//  * Hessian, mixed second difference of phi: truncation ~ h^2, round-off ~ eps |phi| / h^2;
//    smallest at h ~ eps^(1/4) ~ 1.2e-4, relative error ~ sqrt(eps) ~ 1.5e-8.
// The tolerances used by the tests (1e-6 and 1e-5 relative) sit two to three orders above these
// estimates to absorb the unknown third and fourth derivatives, and far below the size of any
// real mistake (a missing term is O(1) relative).
#pragma once

#include "core/small_math.hpp"
#include "model/state.hpp"

#include <functional>
#include <random>
#include <vector>

namespace fascia::test {

using Energy = std::function<double(const State&)>;

// Central differences of a scalar function of a 3x3 matrix, entry by entry:
// (f(F + h E_rc) - f(F - h E_rc)) / (2h).
template <class Function>
Mat3 central_difference(const Function& f, const Mat3& F, double h) {
  Mat3 D;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      Mat3 Fp = F, Fm = F;
      Fp.m[r][c] += h;
      Fm.m[r][c] -= h;
      D.m[r][c] = (f(Fp) - f(Fm)) / (2 * h);
    }
  return D;
}

inline State perturbed(const Model& model, const State& s, const std::vector<double>& d, double h) {
  State t = s;
  retract(model, t, d.data(), h);
  return t;
}

// Central difference of phi along d: (phi(h d) - phi(-h d)) / (2h).
inline double directional_derivative(const Model& model, const Energy& energy, const State& s,
                                     const std::vector<double>& d, double h = 6e-6) {
  return (energy(perturbed(model, s, d, h)) - energy(perturbed(model, s, d, -h))) / (2 * h);
}

// Mixed second difference of phi along d and e: e^T H d.
inline double mixed_second_derivative(const Model& model, const Energy& energy, const State& s,
                                      const std::vector<double>& d, const std::vector<double>& e, double h = 1.2e-4) {
  auto at = [&](double a, double b) {
    std::vector<double> v(d.size());
    for (size_t k = 0; k < v.size(); ++k) v[k] = a * d[k] + b * e[k];
    return energy(perturbed(model, s, v, 1.0));
  };
  return (at(h, h) - at(h, -h) - at(-h, h) + at(-h, -h)) / (4 * h * h);
}

// A random increment [N][6]: translations uniform in [-length_scale, length_scale] (m), rotations
// in [-1, 1] (rad), so both parts have comparable effect on a model of that size.
inline std::vector<double> random_direction(const Model& model, unsigned seed, double length_scale) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> d(model.dof_count());
  for (int i = 0; i < model.frame_count(); ++i)
    for (int k = 0; k < 6; ++k) d[6 * i + k] = (k < 3 ? length_scale : 1.0) * u(rng);
  return d;
}

inline double dot(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (size_t k = 0; k < a.size(); ++k) s += a[k] * b[k];
  return s;
}

inline double norm(const std::vector<double>& a) { return std::sqrt(dot(a, a)); }

}  // namespace fascia::test
