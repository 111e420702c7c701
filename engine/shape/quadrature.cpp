#include "shape/quadrature.hpp"

#include <cmath>
#include <stdexcept>

namespace fascia {

std::vector<QuadraturePoint> tet_quadrature(int points) {
  if (points == 1) return {{{0.25, 0.25, 0.25}, 1.0 / 6.0}};
  if (points == 4) {
    // Keast / Hammer-Stroud degree-2 rule: a = (5 - sqrt 5)/20, b = (5 + 3 sqrt 5)/20.
    const double a = (5.0 - std::sqrt(5.0)) / 20.0;
    const double b = (5.0 + 3.0 * std::sqrt(5.0)) / 20.0;
    const double w = 1.0 / 24.0;
    return {{{a, a, a}, w}, {{b, a, a}, w}, {{a, b, a}, w}, {{a, a, b}, w}};
  }
  throw std::invalid_argument("tetrahedron quadrature: 1 or 4 points");
}

std::vector<QuadraturePoint> hex_quadrature(int n) {
  std::vector<double> x, w;
  if (n == 1) {
    x = {0.0};
    w = {2.0};
  } else if (n == 2) {
    const double g = 1.0 / std::sqrt(3.0);
    x = {-g, g};
    w = {1.0, 1.0};
  } else if (n == 3) {
    const double g = std::sqrt(0.6);
    x = {-g, 0.0, g};
    w = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
  } else {
    throw std::invalid_argument("hexahedron quadrature: 1, 2 or 3 points per axis");
  }
  std::vector<QuadraturePoint> q;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) q.push_back({{x[i], x[j], x[k]}, w[i] * w[j] * w[k]});
  return q;
}

}  // namespace fascia
