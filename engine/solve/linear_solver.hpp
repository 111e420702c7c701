// Linear solves of the Newton system H d = b on the free degrees of freedom, on the CPU.
//
// Fixed DOFs leave the unknowns: CG and PCG (solve/pcg.hpp) project them out, the sparse
// Cholesky factorisation (solve/sparse_cholesky.hpp) factorises the free-free block.
// Methods (docs/solvers.md):
//   cg       conjugate gradients, matrix-free
//   pcg      PCG, matrix-free products, preconditioned by `preconditioner`:
//              block_jacobi  the inverse 6x6 diagonal blocks (solve/block_jacobi.hpp)
//              cholmod       a sparse Cholesky factorisation of the assembled H, kept from one
//                            solve to the next (Newton iterations and steps) and renewed when it
//                            stops paying (solve/kept_factorisation.hpp)
//   cholmod  direct: assemble and factorise H at every solve (symbolic analysis kept)
#pragma once

#include "solve/kept_factorisation.hpp"
#include "solve/linear_result.hpp"

#include <Eigen/SparseCore>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace fascia {

class SparseCholesky;

enum class LinearMethod { cg, pcg, cholmod };
enum class Preconditioner { block_jacobi, cholmod };

const char* to_string(LinearMethod method);
const char* to_string(Preconditioner preconditioner);
// Parse "cg" | "pcg" | "cholmod" and "block_jacobi" | "cholmod"; throw std::invalid_argument
// otherwise.
LinearMethod parse_linear_method(const std::string& name);
Preconditioner parse_preconditioner(const std::string& name);

struct LinearSettings {
  LinearMethod method = LinearMethod::pcg;
  Preconditioner preconditioner = Preconditioner::cholmod;
  double tolerance = 1e-8;    // CG/PCG: stop when |r| <= tolerance |b|
  int max_iterations = 2000;  // CG/PCG cap
  bool fixed_iterations = false;  // run exactly max_iterations (the paper's benchmarks: 60)
};

// A CHOLMOD factorisation's cost (assembly and numeric factorisation) in CG iterations of the
// solves it serves, for the renewal rule of solve/kept_factorisation.hpp: the shipped scenes
// measure 54 (liver) to 149 (bone) on one thread of a 2-core VM, 70 for the pelvis.
constexpr double kCholmodFactorisationCost = 100;

// The system's operator H (size n = 6N), its 6x6 diagonal blocks and assembled form on demand.
struct LinearSystem {
  int size = 0;
  const std::uint8_t* fixed = nullptr;                          // [n] 1 = fixed DOF
  std::function<void(const double*, double*)> apply;           // out = H d
  std::function<void(double*)> diagonal_blocks;                 // [N][36]
  std::function<Eigen::SparseMatrix<double>()> assemble;        // H, both triangles
};

// Solves with the method of the settings. Keeps the sparse factorisation between solves (pcg +
// cholmod reuses it as its preconditioner; cholmod reuses the symbolic analysis): one solver per
// sequence of systems of one model.
class LinearSolver {
 public:
  LinearSolver();
  ~LinearSolver();
  LinearSolver(const LinearSolver&) = delete;
  LinearSolver& operator=(const LinearSolver&) = delete;

  // Solves H x = b for x (resized to n). b is projected onto the free DOFs.
  LinearResult solve(const LinearSystem& system, const LinearSettings& settings, const std::vector<double>& b,
                     std::vector<double>& x);

  const SparseCholesky& factorisation() const { return *m_cholesky; }

  // pcg + cholmod: whether the next solve reuses the held factorisation (it is current, not
  // stale), and the solves it has served. A checkpoint keeps where it was computed
  // (integrate/tangent_origin.hpp) and those counts.
  bool reuses_factorisation() const;
  const KeptFactorisation& kept() const { return m_kept; }
  // Factorises `system` as the factorisation the next pcg + cholmod solves reuse, having served
  // `served` (solves and iterations), with the shift step it had: a resumed run factorises the
  // matrix the interrupted run held, so that its solves and renewals are bitwise the same.
  // Returns false when even the largest shift fails (the next solve factorises again).
  bool restore_factorisation(const LinearSystem& system, const KeptFactorisation& served, int shift_step);
  // A resumed run holding no factorisation: the next factorisation searches for a shift from
  // where the interrupted run's would, after a last factorisation of shift step `shift_step`.
  void restore_shift(int shift_step);

 private:
  LinearResult factorise(const LinearSystem& system);

  std::unique_ptr<SparseCholesky> m_cholesky;
  KeptFactorisation m_kept;  // pcg + cholmod: the held factorisation's state
};

}  // namespace fascia
