// Isochoric invariants (material/isochoric.hpp): gradient and differential against central
// differences, symmetry, and invariance under dilatation.
#include "material/isochoric.hpp"
#include "support/finite_difference.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace fascia;

namespace {

double frobenius(const Mat3& a) { return std::sqrt(ddot(a, a)); }

double phi(const Mat3& F, const Mat3& A) { return isochoric_invariant(F, A, std::pow(det(F), -2.0 / 3)); }

}  // namespace

TEST_CASE("isochoric invariants: D_A = dphi_A/dF and dD_A by central differences", "[material][isochoric][fd]") {
  // A = I (I1bar) and a dispersed structure tensor kappa I + (1 - 3 kappa) a a (a unit).
  const Vec3 a = (1 / std::sqrt(0.98)) * Vec3{0.8, 0.5, -0.3};
  const Mat3 A = GENERATE_COPY(identity3(), 0.1 * identity3() + 0.7 * outer(a, a));
  const Mat3 F = GENERATE(Mat3{{{1.1, 0.2, -0.05}, {0.03, 0.9, 0.1}, {-0.1, 0.05, 1.2}}},
                          Mat3{{{1.3, 0.35, 0.1}, {-0.2, 0.95, 0.15}, {0.05, -0.1, 0.9}}});
  const Mat3 G = inverse_transpose(F);
  const double j = std::pow(det(F), -2.0 / 3);
  const Mat3 D = isochoric_invariant_gradient(F, A, G, j);
  // h = cbrt(eps) = 6e-6 as tests/support/finite_difference.hpp derives: ~1e-10 relative error
  // for these O(1) smooth functions; 1e-7 leaves margin and is far below a wrong term.
  const double h = 6e-6;
  const Mat3 fd = test::central_difference([&](const Mat3& X) { return phi(X, A); }, F, h);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) REQUIRE(std::abs(fd.m[r][c] - D.m[r][c]) <= 1e-7 * frobenius(D));
  const Mat3 dF = Mat3{{{0.3, -0.2, 0.1}, {0.5, 0.1, -0.4}, {0.2, 0.3, 0.6}}};
  const Mat3 dD = isochoric_invariant_differential(F, A, G, j, dF);
  const auto grad = [&](const Mat3& X) {
    return isochoric_invariant_gradient(X, A, inverse_transpose(X), std::pow(det(X), -2.0 / 3));
  };
  REQUIRE(frobenius((1 / (2 * h)) * (grad(F + h * dF) - grad(F - h * dF)) - dD) <= 1e-7 * frobenius(dD));
  // A Hessian: dF2 : dD[dF] = dF : dD[dF2], to rounding.
  const Mat3 dF2 = Mat3{{{-0.1, 0.4, 0.2}, {0.3, -0.5, 0.1}, {0.6, 0.2, -0.3}}};
  REQUIRE(std::abs(ddot(dF2, dD) - ddot(dF, isochoric_invariant_differential(F, A, G, j, dF2))) <=
          1e-13 * frobenius(dD) * frobenius(dF2));
  // phi_A(s F) = phi_A(F) for s > 0, so D_A : F = 0 (Euler's theorem for degree 0).
  REQUIRE(phi(1.7 * F, A) == Approx(phi(F, A)).epsilon(1e-14));
  REQUIRE(std::abs(ddot(D, F)) <= 1e-14 * frobenius(D) * frobenius(F));
}
