// What a linear solve of the Newton system reports, whatever the method or backend.
#pragma once

#include <string>

namespace fascia {

struct LinearResult {
  int iterations = 0;               // CG/PCG iterations (0 for a direct solve)
  double relative_residual = 0;     // |H x - b| / |b| on the free DOFs
  bool converged = false;
  bool negative_curvature = false;  // CG met d^T H d <= 0 and stopped there (truncated Newton)
  bool shifted = false;             // the factorised matrix was H + tau diag|H| (H not positive definite)
  bool factorised = false;          // a numeric factorisation was computed for this solve
  std::string message;
};

}  // namespace fascia
