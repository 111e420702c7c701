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
// and the scalars of a PCG iteration (solve/pcg.hpp), kept where the backend computes:
//
//   static constexpr bool kScalarsOnHost;            cg_status() costs nothing (read every iteration)
//   using CgScalars = ...;                           rho = r^T z, alpha, beta, the status below
//   void cg_start(CgScalars& s, const Vector& r, const Vector& z, double tolerance) const;
//       r = P b, the residual of x = 0 (z: the preconditioned residual's vector, r itself in
//       plain CG): b_norm = |r|; running, no iteration taken, beta = 0 (the first direction is
//       P z); stop when |r| <= tolerance b_norm (negative: never); stopped at once where b = 0
//   void cg_step(CgScalars& s, const Vector& p, const Vector& hp, const Vector& z, Vector& x, Vector& r) const;
//       while running, with p and r projected and hp, z read through the projection P: c = p^T hp;
//       c > 0: alpha = rho / c, x += alpha p, r -= alpha P hp, one more iteration, stopped when
//       |r| / b_norm <= tolerance; otherwise stopped with negative curvature (x = P z when no
//       iteration was taken). The residual is |r| / b_norm in either case.
//   void cg_direction(CgScalars& s, const Vector& r, const Vector& z, Vector& p) const;
//       while running: rho' = r^T z, beta = rho' / rho (0 before the first step), rho = rho',
//       p = P z + beta p
//   z may be r itself (plain CG: pcg.hpp's IdentityPreconditioner), in all three; a backend may then
//   form rho' = r^T r in cg_step with the residual, as the device does.
// (r^T z = r^T P z and p^T hp = p^T P hp, r and p being projected: P is applied where a
// vector is written; the device does it in the pass that writes it.)
//   CgStatus cg_status(const CgScalars& s) const;    the status, on the host
//   template <class Body> auto repeated(Body& body) const;
//       an object whose run(count) calls body() count times in order (count <= 0: none); body
//       only enqueues the backend's work and reads nothing back, so that a device may record it
//       at the first run and replay the record (the object lives while body's data does)
//
// Other scalars (dot, norm, Newton's step lengths) are host doubles: the solvers' control flow runs
// on the host, as mfem's does. Operators and preconditioners are callables over Vector
// (solve/pcg.hpp); Newton's problem supplies its states (newton.hpp).
//
// HostVectorOps below is the CPU backend: std::vector<double>, SIMD loops.
#pragma once

#include "solve/linear_result.hpp"

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

  // y = y + a P x.
  void axpy_projected(double a, const Vector& x, Vector& y) const {
    if (!m_fixed) return axpy(a, x, y);
    const std::uint8_t* __restrict fixed = m_fixed;
    const double* __restrict xd = x.data();
    double* __restrict yd = y.data();
#pragma omp simd
    for (int k = 0; k < m_n; ++k) yd[k] += fixed[k] ? 0.0 : a * xd[k];
  }

  static constexpr bool kScalarsOnHost = true;
  struct CgScalars {
    CgStatus status;
    double rho = 0, b_norm = 0, tolerance = 0;
  };
  void cg_start(CgScalars& s, const Vector& r, const Vector&, double tolerance) const {
    s = CgScalars{};
    s.b_norm = norm(r);
    s.tolerance = tolerance;
    s.status.stopped = s.b_norm == 0;
  }
  void cg_step(CgScalars& s, const Vector& p, const Vector& hp, const Vector& z, Vector& x, Vector& r) const {
    if (s.status.stopped) return;
    const double curvature = dot(p, hp);
    if (!(curvature > 0)) {
      if (s.status.iterations == 0) {  // preconditioned steepest descent
        copy(z, x);
        project(x);
      }
      s.status.stopped = s.status.negative_curvature = true;
      s.status.relative_residual = norm(r) / s.b_norm;
      return;
    }
    const double alpha = s.rho / curvature;
    axpy(alpha, p, x);
    axpy_projected(-alpha, hp, r);
    ++s.status.iterations;
    s.status.relative_residual = norm(r) / s.b_norm;
    s.status.stopped = s.status.relative_residual <= s.tolerance;
  }
  void cg_direction(CgScalars& s, const Vector& r, const Vector& z, Vector& p) const {
    if (s.status.stopped) return;
    const double rho = dot(r, z);
    const double beta = s.status.iterations == 0 ? 0.0 : rho / s.rho;
    s.rho = rho;
    xpay(z, beta, p);
    project(p);
  }
  CgStatus cg_status(const CgScalars& s) const { return s.status; }
  template <class Body>
  struct Repeated {
    Body& body;
    void run(int count) {
      for (int k = 0; k < count; ++k) body();
    }
  };
  template <class Body>
  Repeated<Body> repeated(Body& body) const {
    return Repeated<Body>{body};
  }

 private:
  int m_n;
  const std::uint8_t* m_fixed;
};

}  // namespace fascia
