// Block-Jacobi preconditioner: the inverse of each frame's 6x6 diagonal block of H.
//
// Fixed DOFs get identity rows and columns. A block that is not positive definite (possible away
// from equilibrium: geometric stiffness) is replaced by the inverse of its absolute diagonal,
// which keeps the preconditioner symmetric positive definite.
#pragma once

#include <cstdint>
#include <vector>

namespace fascia {

class BlockJacobi {
 public:
  // @param blocks [N][36] row-major 6x6 diagonal blocks of H (N = n / 6); @param fixed [n] or null.
  BlockJacobi(std::vector<double> blocks, const std::uint8_t* fixed);
  // z = M^{-1} r, [n] each.
  void apply(const std::vector<double>& r, std::vector<double>& z) const;

 private:
  std::vector<double> m_inverse;  // [N][36]
};

}  // namespace fascia
