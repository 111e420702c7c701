// The vector operations the solvers are written over (solve/pcg.hpp, solve/newton.hpp): one PCG
// and one Newton run on any backend that provides them, as mfem's CGSolver runs over Vector and
// warp's cg over its arrays.
//
// A backend's operations are a class `Ops` bound to a vector size n and a mask of fixed degrees
// of freedom (the projection: fixed DOFs leave the unknowns, DESIGN.md). It provides
//
//   using Vector = ...;                              n doubles where the backend computes
//   int size() const;                                n
//   void resize(Vector& x) const;                    x holds n values (contents unspecified)
//   void fill(Vector& x, double a) const;            x = a
//   void copy(const Vector& x, Vector& y) const;     y = x
//   void axpy(double a, const Vector& x, Vector& y) const;   y = y + a x
//   void xpay(const Vector& x, double a, Vector& y) const;   y = x + a y
//   void scale(double a, Vector& x) const;           x = a x
//   double dot(const Vector& x, const Vector& y) const;      x^T y, a fixed summation order for
//                                                            a given build (reproducible runs)
//   double norm(const Vector& x) const;              sqrt(x^T x)
//   void project(Vector& x) const;                   x_k = 0 at every fixed DOF k
//
// Scalars (dot, norm, the step lengths) are host doubles: the solvers' control flow runs on the
// host and reads one or two scalars per iteration, as mfem's does. Operators and preconditioners
// are callables over Vector (solve/pcg.hpp); Newton's problem supplies its states (newton.hpp).
//
// HostVectorOps below is the CPU backend: std::vector<double>, SIMD loops.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

namespace fascia {

class HostVectorOps {
 public:
  using Vector = std::vector<double>;

  // @param fixed [n] 1 = fixed DOF, or null (nothing fixed); must outlive this object.
  HostVectorOps(int n, const std::uint8_t* fixed) : m_n(n), m_fixed(fixed) {}

  int size() const { return m_n; }
  void resize(Vector& x) const { x.resize(static_cast<size_t>(m_n)); }
  void fill(Vector& x, double a) const { x.assign(static_cast<size_t>(m_n), a); }
  void copy(const Vector& x, Vector& y) const { y.assign(x.begin(), x.end()); }

  void axpy(double a, const Vector& x, Vector& y) const {
    const double* __restrict xd = x.data();
    double* __restrict yd = y.data();
#pragma omp simd
    for (int k = 0; k < m_n; ++k) yd[k] += a * xd[k];
  }

  void xpay(const Vector& x, double a, Vector& y) const {
    const double* __restrict xd = x.data();
    double* __restrict yd = y.data();
#pragma omp simd
    for (int k = 0; k < m_n; ++k) yd[k] = xd[k] + a * yd[k];
  }

  void scale(double a, Vector& x) const {
    double* __restrict xd = x.data();
#pragma omp simd
    for (int k = 0; k < m_n; ++k) xd[k] *= a;
  }

  // A SIMD reduction: a fixed summation order for a given build, independent of the thread count.
  double dot(const Vector& x, const Vector& y) const {
    const double* __restrict xd = x.data();
    const double* __restrict yd = y.data();
    double s = 0;
#pragma omp simd reduction(+ : s)
    for (int k = 0; k < m_n; ++k) s += xd[k] * yd[k];
    return s;
  }

  double norm(const Vector& x) const { return std::sqrt(dot(x, x)); }

  void project(Vector& x) const {
    if (!m_fixed) return;
    const std::uint8_t* __restrict fixed = m_fixed;
    double* __restrict xd = x.data();
#pragma omp simd
    for (int k = 0; k < m_n; ++k) xd[k] = fixed[k] ? 0.0 : xd[k];
  }

  const std::uint8_t* fixed() const { return m_fixed; }

 private:
  int m_n;
  const std::uint8_t* m_fixed;
};

}  // namespace fascia
