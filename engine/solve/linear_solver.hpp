// Linear solves for the Newton step H d = -g on the free degrees of freedom.
//
// Fixed DOFs leave the unknowns: CG and PCG project them out (the operator, right-hand side and
// every iterate have zeros there); CHOLMOD factorises the free-free block of the assembled H.
#pragma once

#include <Eigen/SparseCore>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace fascia {

enum class LinearMethod { cg, pcg, cholmod };

const char* to_string(LinearMethod method);
// Parses "cg", "pcg" or "cholmod"; throws std::invalid_argument otherwise.
LinearMethod parse_linear_method(const std::string& name);

struct LinearSettings {
  LinearMethod method = LinearMethod::pcg;
  double tolerance = 1e-8;    // CG/PCG: stop when |r| <= tolerance |b| (preconditioned norm for PCG)
  int max_iterations = 2000;  // CG/PCG cap
  bool fixed_iterations = false;  // run exactly max_iterations (the paper's benchmarks: 60)
};

// The system's operator H (size n = 6N), its 6x6 diagonal blocks and assembled form on demand.
struct LinearSystem {
  int size = 0;
  const std::uint8_t* fixed = nullptr;                          // [n] 1 = fixed DOF
  std::function<void(const double*, double*)> apply;           // out = H d
  std::function<void(double*)> diagonal_blocks;                 // [N][36]
  std::function<Eigen::SparseMatrix<double>()> assemble;        // H, both triangles
};

struct LinearResult {
  int iterations = 0;
  double relative_residual = 0;
  bool converged = false;
  bool negative_curvature = false;  // CG met d^T H d <= 0 and stopped there (truncated Newton)
  bool fell_back = false;           // CHOLMOD found H not positive definite and PCG was used
  std::string message;
};

// Solves H x = b for x (resized to n). b must be zero at fixed DOFs (it is projected anyway).
LinearResult solve_linear(const LinearSystem& system, const LinearSettings& settings, const std::vector<double>& b,
                          std::vector<double>& x);

}  // namespace fascia
