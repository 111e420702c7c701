// Second-order forward-mode differentiation: a Jet<N> carries a value, its gradient and its
// Hessian with respect to N independent variables, propagated exactly through +, -, *, / and
// sqrt (the chain rule to second order). Used where an element energy is written once and its
// exact gradient and symmetric Hessian are needed (mechanics/shell.cpp); the results are exact
// up to round-off, not approximations.
//
// Cost: a product is O(N^2); meant for small element-level N (18 for a triangle of 6-DOF nodes).
#pragma once

#include <cmath>

namespace fascia {

template <int N>
struct Jet {
  double v = 0;
  double g[N] = {};
  double h[N][N] = {};  // symmetric

  Jet() = default;
  explicit Jet(double value) : v(value) {}
  // The k-th independent variable at value x.
  static Jet variable(double x, int k) {
    Jet j(x);
    j.g[k] = 1;
    return j;
  }
};

template <int N>
Jet<N> operator+(const Jet<N>& a, const Jet<N>& b) {
  Jet<N> c;
  c.v = a.v + b.v;
  for (int i = 0; i < N; ++i) c.g[i] = a.g[i] + b.g[i];
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) c.h[i][j] = a.h[i][j] + b.h[i][j];
  return c;
}

template <int N>
Jet<N> operator-(const Jet<N>& a, const Jet<N>& b) {
  Jet<N> c;
  c.v = a.v - b.v;
  for (int i = 0; i < N; ++i) c.g[i] = a.g[i] - b.g[i];
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) c.h[i][j] = a.h[i][j] - b.h[i][j];
  return c;
}

template <int N>
Jet<N> operator-(const Jet<N>& a) {
  return Jet<N>(0.0) - a;
}

template <int N>
Jet<N> operator*(double s, const Jet<N>& a) {
  Jet<N> c;
  c.v = s * a.v;
  for (int i = 0; i < N; ++i) c.g[i] = s * a.g[i];
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) c.h[i][j] = s * a.h[i][j];
  return c;
}

template <int N>
Jet<N> operator*(const Jet<N>& a, double s) {
  return s * a;
}

template <int N>
Jet<N> operator+(const Jet<N>& a, double s) {
  Jet<N> c = a;
  c.v += s;
  return c;
}

template <int N>
Jet<N> operator-(const Jet<N>& a, double s) {
  Jet<N> c = a;
  c.v -= s;
  return c;
}

// (ab)'' = a'' b + a b'' + a' b'^T + b' a'^T
template <int N>
Jet<N> operator*(const Jet<N>& a, const Jet<N>& b) {
  Jet<N> c;
  c.v = a.v * b.v;
  for (int i = 0; i < N; ++i) c.g[i] = a.g[i] * b.v + a.v * b.g[i];
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j)
      c.h[i][j] = a.h[i][j] * b.v + a.v * b.h[i][j] + a.g[i] * b.g[j] + b.g[i] * a.g[j];
  return c;
}

// f(a) for a scalar function with f(a.v) = f0, f'(a.v) = f1, f''(a.v) = f2:
// f(a)' = f1 a', f(a)'' = f1 a'' + f2 a' a'^T.
template <int N>
Jet<N> chain(const Jet<N>& a, double f0, double f1, double f2) {
  Jet<N> c;
  c.v = f0;
  for (int i = 0; i < N; ++i) c.g[i] = f1 * a.g[i];
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) c.h[i][j] = f1 * a.h[i][j] + f2 * a.g[i] * a.g[j];
  return c;
}

template <int N>
Jet<N> sqrt(const Jet<N>& a) {
  const double s = std::sqrt(a.v);
  return chain(a, s, 0.5 / s, -0.25 / (s * a.v));
}

// 1 / a
template <int N>
Jet<N> reciprocal(const Jet<N>& a) {
  const double r = 1.0 / a.v;
  return chain(a, r, -r * r, 2 * r * r * r);
}

template <int N>
Jet<N> operator/(const Jet<N>& a, const Jet<N>& b) {
  return a * reciprocal(b);
}

// Plain doubles share the interface so that element energies can be written once as templates.
inline double reciprocal(double a) { return 1.0 / a; }
inline double value_of(double a) { return a; }
template <int N>
double value_of(const Jet<N>& a) {
  return a.v;
}

}  // namespace fascia
