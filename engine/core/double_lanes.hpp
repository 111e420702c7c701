// DoubleLanes: four doubles computed together, one per lane of an AVX2 register (GCC's vector
// extension; two SSE2 registers in the plain x86-64 clone, core/target_clones.hpp). A scalar type
// for the templated small-matrix code (core/small_math.hpp): the same formulas evaluate four
// independent problems at once, lane by lane, with the rounding of the scalar code up to the
// contraction of products into FMAs. Host code only, and only inlined: its users are
// FASCIA_CLONES functions marked flatten, since a call between code compiled for different
// instruction sets would pass the 32-byte vector in different places.
#pragma once

#include <cmath>

namespace fascia {

constexpr int kDoubleLanes = 4;

struct DoubleLanes {
  // Aligned to its size in every clone: without AVX, GCC would give a 32-byte vector 16-byte
  // alignment, while the AVX2 clone's code assumes 32.
  typedef double Vector __attribute__((vector_size(kDoubleLanes * sizeof(double)), aligned(kDoubleLanes * sizeof(double))));
  Vector v;

  DoubleLanes() = default;
  DoubleLanes(double x) : v{x, x, x, x} {}  // NOLINT(google-explicit-constructor): a scalar broadcasts
  explicit DoubleLanes(Vector x) : v(x) {}
  double operator[](int lane) const { return v[lane]; }
  double& operator[](int lane) { return v[lane]; }

  DoubleLanes& operator+=(DoubleLanes b) { v += b.v; return *this; }
  DoubleLanes& operator-=(DoubleLanes b) { v -= b.v; return *this; }
  DoubleLanes& operator*=(DoubleLanes b) { v *= b.v; return *this; }
};

inline DoubleLanes operator+(DoubleLanes a, DoubleLanes b) { return DoubleLanes(a.v + b.v); }
inline DoubleLanes operator-(DoubleLanes a, DoubleLanes b) { return DoubleLanes(a.v - b.v); }
inline DoubleLanes operator*(DoubleLanes a, DoubleLanes b) { return DoubleLanes(a.v * b.v); }
inline DoubleLanes operator/(DoubleLanes a, DoubleLanes b) { return DoubleLanes(a.v / b.v); }
inline DoubleLanes operator-(DoubleLanes a) { return DoubleLanes(-a.v); }

// Lane-wise square root (found by small_math's unqualified sqrt).
inline DoubleLanes sqrt(DoubleLanes a) {
  DoubleLanes r;
  for (int l = 0; l < kDoubleLanes; ++l) r.v[l] = std::sqrt(a.v[l]);
  return r;
}

}  // namespace fascia
