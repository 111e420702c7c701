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
  bool product_failed = false;      // the operator's product could not be formed (GMRES: a difference
                                    // quotient's state is not admissible); x = 0
  std::string message;
};

// Where a PCG solve stands (the CgScalars of solve/vector_ops.hpp).
struct CgStatus {
  int iterations = 0;              // iterations taken (updates of x)
  double relative_residual = 0;    // |r| / |b| after them
  bool stopped = false;            // converged or negative curvature: later iterations change nothing
  bool negative_curvature = false;
};

}  // namespace fascia
