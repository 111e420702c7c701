// Exceptions that no command handles: those that reach main() and those that leave a worker thread
// (an OpenMP or TBB task), which would otherwise end the process in std::terminate with SIGABRT.
// Each maps to its documented exit code and a one-line message.
#pragma once

#include <exception>
#include <string>

namespace fascia::app {

struct Failure {
  int exit_code = 0;
  std::string message;  // one line for stderr, without the trailing newline
};

// The exit code and message for an exception no command caught:
//  - SolverError (Newton failure, divergence): kSolverFailed, its message;
//  - std::bad_alloc (an allocation beyond what --max-memory estimated): kTooLarge, "out of memory";
//  - anything else (std::exception or not): kSoftware, "internal error", with the type and what().
// Precondition: error is not null.
Failure classify_unexpected(std::exception_ptr error);

// std::set_terminate with a handler that prints classify_unexpected(std::current_exception()) and
// ends the process with its exit code (_exit: other threads may still run; the trajectory's complete
// steps are flushed as they are written). Without a current exception: kSoftware.
void install_terminate_handler();

}  // namespace fascia::app
