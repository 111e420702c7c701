// The closed-form gradient and Hessian of one shell triangle (mechanics/shell_element.hpp) against
// central differences of its energy, re-parametrised around the base point:
// phi(theta) = W(x_i + dx_i, exp([dr_i]x) R_i).
#include "core/rotation.hpp"
#include "mechanics/shell.hpp"
#include "mechanics/shell_element.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <random>

using namespace fascia;

namespace {

// One triangle at rest, its moduli, and a deformed state (x, R).
struct ElementCase {
  ShellElementRest rest;
  ShellModuli moduli;
  Vec3 x[3];
  Mat3 R[3];
  double length;  // smallest rest altitude 2A / (longest edge), m: the element's shortest length scale
};

// shape 0: near-equilateral, 1: obtuse and skinny (angle near 150 degrees), 2: a right triangle
// tilted out of every coordinate plane. Strains of `displacement` (relative to the smallest altitude),
// nodal rotations up to `rotation` rad on top of a rigid rotation of 2.1 rad.
ElementCase make_case(int shape, bool membrane, double displacement, double rotation, unsigned seed) {
  const double rest_shapes[3][9] = {{0, 0, 0, 0.02, 0, 0, 0.01, 0.017, 0.001},
                                    {0, 0, 0, 0.03, 0, 0, -0.012, 0.006, 0},
                                    {0.01, -0.02, 0.005, 0.025, -0.01, 0.015, 0.004, 0.002, 0.02}};
  Shell shell;
  shell.thickness = 0.004, shell.young = 5.0e4, shell.poisson = 0.35, shell.density = 1000;
  ElementCase c;
  c.rest = make_shell_element(rest_shapes[shape], 0, 1, 2, shell);
  c.moduli = make_shell_moduli(shell.young, shell.poisson, shell.thickness);
  if (!membrane) c.moduli.mu = c.moduli.lambda = 0;  // bending and drilling alone, at their own scale
  double longest_edge = 0;
  for (int i = 0; i < 3; ++i) longest_edge = std::max(longest_edge, norm(c.rest.rest[(i + 1) % 3] - c.rest.rest[i]));
  c.length = 2 * c.rest.area / longest_edge;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Quat Q = quat_exp(Vec3{1.2, -1.4, 0.9});  // |.| = 2.1 rad
  const Mat3 RQ = rotation_matrix(Q);
  for (int i = 0; i < 3; ++i) {
    const Vec3 noise{u(rng), u(rng), u(rng)};
    c.x[i] = RQ * c.rest.rest[i] + Vec3{0.1, -0.2, 0.05} + (displacement * c.length) * noise;
    const Vec3 r{rotation * u(rng), rotation * u(rng), rotation * u(rng)};
    c.R[i] = rotation_matrix(normalized(quat_exp(r) * Q));
  }
  return c;
}

// phi(theta) for an 18-vector theta.
double energy_at(const ElementCase& c, const double* theta) {
  Vec3 x[3];
  Mat3 R[3];
  for (int i = 0; i < 3; ++i) {
    x[i] = c.x[i] + load3(theta + 6 * i);
    R[i] = rotation_matrix(quat_exp(load3(theta + 6 * i + 3))) * c.R[i];
  }
  return shell_element_energy(c.rest, c.moduli, x, R);
}

}  // namespace

TEST_CASE("shell element gradient and Hessian are the derivatives of its energy", "[mechanics][shell][fd]") {
  const int shape = GENERATE(0, 1, 2);
  const bool membrane = GENERATE(true, false);
  const double rotation = GENERATE(0.05, 0.6);
  const ElementCase c = make_case(shape, membrane, 0.05, rotation, 11 + shape);
  INFO("shape " << shape << " membrane " << membrane << " rotation " << rotation);
  const int n = kShellElementDofs;
  // Variables scaled to O(1): translations in units of the element's shortest length L (its
  // smallest altitude: a skinny triangle's strains vary on that scale), rotations in rad.
  double scale[kShellElementDofs];
  for (int k = 0; k < n; ++k) scale[k] = k % 6 < 3 ? c.length : 1.0;

  double g[kShellElementDofs], g_only[kShellElementDofs], H[kShellElementDofs * kShellElementDofs];
  const double w = shell_element_hessian(c.rest, c.moduli, c.x, c.R, g, H);
  const double w_only = shell_element_gradient(c.rest, c.moduli, c.x, c.R, g_only);
  const double zero[kShellElementDofs] = {};
  REQUIRE(w > 0);
  REQUIRE(w == Approx(energy_at(c, zero)).epsilon(1e-14));
  REQUIRE(w_only == w);
  for (int k = 0; k < n; ++k) REQUIRE(g_only[k] == g[k]);

  // Gradient, central differences of phi in the scaled variables: truncation h^2 |phi'''| / 6,
  // round-off eps |phi| / h, smallest at h = cbrt(eps) = 6e-6 with an error ~ 4e-11 max(|phi|,
  // |phi'''|). With strains and rotations of O(0.05..0.6), |phi| and |phi'''| are at most of the
  // order of the largest scaled Hessian entry |H|max, and |H|max <= 1e3 |g|max here (the
  // gradient is the Hessian times the O(0.05..1) deformation). Tolerance 1e-7 |H|max: three orders
  // above the estimate, far below the size of a missing term (the membrane-free cases
  // make bending and drilling terms the largest ones).
  double h_max = 0;
  for (int k = 0; k < n * n; ++k) h_max = std::max(h_max, std::abs(H[k] * scale[k / n] * scale[k % n]));
  REQUIRE(h_max > 0);
  for (int k = 0; k < n; ++k) {
    const double h = 6e-6 * scale[k];
    double tp[kShellElementDofs] = {}, tm[kShellElementDofs] = {};
    tp[k] = h, tm[k] = -h;
    const double fd = (energy_at(c, tp) - energy_at(c, tm)) / (2 * h);
    INFO("dof " << k << " fd " << fd << " closed form " << g[k]);
    REQUIRE(std::abs(fd - g[k]) * scale[k] <= 1e-7 * h_max);
  }

  // Hessian, mixed central second differences of phi (both increments in one exponential per
  // node): truncation ~ h^2 |phi''''|, round-off ~ eps |phi| / h^2, smallest at h = eps^(1/4) =
  // 1.2e-4, error ~ 1.5e-8 max(|phi|, |phi''''|) <~ 1.5e-8 |H|max. Tolerance 1e-6 |H|max.
  for (int k = 0; k < n; ++k)
    for (int l = 0; l < n; ++l) {
      const double hk = 1.2e-4 * scale[k], hl = 1.2e-4 * scale[l];
      auto at = [&](double a, double b) {
        double t[kShellElementDofs] = {};
        t[k] += a * hk;
        t[l] += b * hl;
        return energy_at(c, t);
      };
      const double fd = (at(1, 1) - at(1, -1) - at(-1, 1) + at(-1, -1)) / (4 * hk * hl);
      INFO("entry " << k << ", " << l << " fd " << fd << " closed form " << H[n * k + l]);
      REQUIRE(std::abs(fd - H[n * k + l]) * scale[k] * scale[l] <= 1e-6 * h_max);
      REQUIRE(H[n * k + l] == H[n * l + k]);
    }
}

TEST_CASE("shell element energy and forces are unchanged by rigid motions", "[mechanics][shell][invariance]") {
  // A rigid motion of every node (x -> Q x + t, R -> Q R) leaves W unchanged and turns the
  // gradient's force and torque parts with Q.
  const int shape = GENERATE(0, 1, 2);
  ElementCase c = make_case(shape, true, 0.05, 0.4, 3);
  double g0[kShellElementDofs], g1[kShellElementDofs];
  const double w0 = shell_element_gradient(c.rest, c.moduli, c.x, c.R, g0);
  const Mat3 Q = rotation_matrix(quat_exp(Vec3{-0.4, 2.2, 1.1}));
  for (int i = 0; i < 3; ++i) {
    c.x[i] = Q * c.x[i] + Vec3{-0.3, 0.7, 0.2};
    c.R[i] = Q * c.R[i];
  }
  const double w1 = shell_element_gradient(c.rest, c.moduli, c.x, c.R, g1);
  REQUIRE(w0 > 0);
  // Round-off: positions near 1 m and element edges of 2 cm lose ~eps / (0.02 * 0.05) ~ 2e-13
  // of the strain, relative; 1e-10 leaves a margin.
  REQUIRE(w1 == Approx(w0).epsilon(1e-10));
  // Forces in N times the element length, torques in N m: comparable sizes.
  double g_max = 0;
  for (int k = 0; k < kShellElementDofs; ++k) g_max = std::max(g_max, std::abs(g0[k]) * (k % 6 < 3 ? c.length : 1.0));
  for (int i = 0; i < 6; ++i) {
    const Vec3 expected = Q * load3(g0 + 3 * i), got = load3(g1 + 3 * i);
    REQUIRE(norm(got - expected) * (i % 2 == 0 ? c.length : 1.0) <= 1e-9 * g_max);
  }
}
