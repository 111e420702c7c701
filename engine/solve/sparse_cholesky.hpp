// A sparse Cholesky factorisation LL^T (CHOLMOD, simplicial or supernodal as its analysis
// chooses) of the free-free block of an assembled
// symmetric matrix H: the direct solve of the Newton system and the reused preconditioner of PCG.
//
// The symbolic analysis (fill-reducing ordering, supernodes) is kept while the free DOFs and the
// sparsity pattern of H stay the same, which they do across the Newton iterations and steps of
// one model; only the numeric factorisation is repeated. A matrix that is not positive definite
// (away from equilibrium the geometric stiffness can make H indefinite) is factorised as
// H + tau diag|H| with the smallest of the shifts tau = 1e-6, 1e-5, ..., 1e3 that succeeds
// (modified Newton: the solve is still a descent direction), searched from the last
// factorisation's shift (solve/diagonal_shifts.hpp).
#pragma once

#include <Eigen/CholmodSupport>
#include <Eigen/SparseCore>

#include <cstdint>
#include <memory>
#include <vector>

namespace fascia {

class SparseCholesky {
 public:
  SparseCholesky();
  ~SparseCholesky();
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;

  // Factorises the free-free block of H (n x n, both triangles or the lower one; fixed: [n] or
  // null). Returns false when even the largest shift fails.
  bool factorise(const Eigen::SparseMatrix<double>& H, const std::uint8_t* fixed);
  // x = (H_ff + tau D)^{-1} b on the free DOFs, zero at fixed ones; [n] each. A supernodal
  // factor is swept here, supernode by supernode, on the calling thread; a simplicial one is
  // solved by CHOLMOD. preconditioner: the solve preconditions PCG, and a supernodal factor of
  // 1e6 entries or more is swept with its values rounded to float (relative changes of 6e-8 in
  // L; sparse_cholesky.cpp), else with the factor's own.
  void solve(const std::vector<double>& b, std::vector<double>& x, bool preconditioner = false) const;

  bool factorised() const { return m_factorised; }
  bool supernodal() const;  // CHOLMOD chose a supernodal factor (solve() sweeps it itself)
  double shift() const { return m_shift; }          // tau of the last factorisation (0: none)
  // The shifts as steps k of kShifts (-1: unshifted; solve/diagonal_shifts.hpp): the last
  // factorisation's, and the first shifted one the next factorisation tries (0 .. 9). A resumed
  // run sets the latter to repeat the shifts of the run it continues (integrate/tangent_origin.hpp).
  int shift_step() const { return m_shift_step; }
  int first_shift_step() const { return m_first_shift_step; }
  void set_first_shift_step(int k);
  int analyses() const { return m_analyses; }       // symbolic analyses so far
  // FNV-1a (64 bits) of the analysed pattern and free-DOF mask: two factorisations of one matrix
  // are bitwise equal when this agrees (the ordering follows the pattern; 0: none analysed).
  std::uint64_t pattern_fingerprint() const { return m_pattern_fingerprint; }
  int factorisations() const { return m_factorisations; }

 private:
  class Factor;  // CHOLMOD's factorisation, with its factor's arrays readable (sparse_cholesky.cpp)
  // OpenMP team for CHOLMOD's and OpenBLAS's factorisation of the analysed factor: one, or at
  // most kMaxFactorThreads where its supernodes are large (sparse_cholesky.cpp).
  int team_size() const;
  std::unique_ptr<Factor> m_factor;
  std::vector<int> m_index;                        // [n] free index of each DOF, -1 if fixed
  std::vector<int> m_free_dofs;                    // [free] the DOF of each free index
  std::vector<std::uint8_t> m_fixed;               // the mask m_index was built from
  std::vector<int> m_outer, m_inner;               // pattern of the analysed reduced matrix
  Eigen::SparseMatrix<double> m_reduced;           // the last factorised lower free-free block
  // The pattern of the last H (compressed) and, per entry of H, its position in m_reduced's
  // values (-1: a fixed row or column, or the upper triangle): found when H's pattern changes,
  // and every factorisation's values are scattered through it.
  std::vector<int> m_source_outer, m_source_inner, m_scatter;
  bool m_analysed = false, m_factorised = false;
  double m_shift = 0;
  int m_shift_step = -1, m_first_shift_step = 0;
  std::uint64_t m_pattern_fingerprint = 0;
  int m_analyses = 0, m_factorisations = 0;
  // The last factorisation's values in float, for preconditioning sweeps (solve); emptied by
  // each factorisation, copied at its first such sweep.
  mutable std::vector<float> m_single_values;
};

}  // namespace fascia
