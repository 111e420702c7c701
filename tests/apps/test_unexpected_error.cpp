#include "exit_code.hpp"
#include "integrate/simulation.hpp"
#include "unexpected_error.hpp"

#include <catch2/catch.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <functional>
#include <iostream>
#include <new>
#include <stdexcept>
#include <string>
#include <thread>

using namespace fascia;
using namespace fascia::app;

namespace {

template <class E>
std::exception_ptr thrown(E e) {
  try {
    throw e;
  } catch (...) {
    return std::current_exception();
  }
}

struct Ended {
  int exit_code = -1;  // -1: killed by a signal
  std::string stderr_text;
};

// Runs `body` in a child process with the terminate handler installed; its exit status and stderr.
Ended run_child(const std::function<void()>& body) {
  int err[2];
  REQUIRE(::pipe(err) == 0);
  std::cout.flush();  // the child must not print the parent's buffered output again
  std::fflush(nullptr);
  const pid_t child = ::fork();
  REQUIRE(child >= 0);
  if (child == 0) {
    ::close(err[0]);
    ::dup2(err[1], STDERR_FILENO);
    install_terminate_handler();
    body();
    ::_exit(0);
  }
  ::close(err[1]);
  Ended ended;
  char buffer[512];
  for (ssize_t n; (n = ::read(err[0], buffer, sizeof buffer)) > 0;) ended.stderr_text.append(buffer, n);
  ::close(err[0]);
  int status = 0;
  ::waitpid(child, &status, 0);
  if (WIFEXITED(status)) ended.exit_code = WEXITSTATUS(status);
  return ended;
}

}  // namespace

TEST_CASE("exceptions no command handles map to their documented exit codes", "[app]") {
  const Failure solver = classify_unexpected(thrown(SolverError("Newton did not converge in 50 iterations")));
  CHECK(solver.exit_code == kSolverFailed);
  CHECK(solver.message == "fascia: error: Newton did not converge in 50 iterations");

  const Failure memory = classify_unexpected(thrown(std::bad_alloc()));
  CHECK(memory.exit_code == kTooLarge);
  CHECK_THAT(memory.message, Catch::Contains("out of memory") && Catch::Contains("--max-memory"));

  // Not a solver failure: exit 70, the type and the message kept.
  const Failure logic = classify_unexpected(thrown(std::logic_error("scene value 'dt' missing after validation")));
  CHECK(logic.exit_code == kSoftware);
  CHECK_THAT(logic.message, Catch::StartsWith("fascia: internal error: std::logic_error: scene value 'dt' missing") &&
                                Catch::Contains("please report"));

  const Failure other = classify_unexpected(thrown(42));
  CHECK(other.exit_code == kSoftware);
  CHECK_THAT(other.message, Catch::Contains("an exception of type int"));
}

TEST_CASE("an exception leaving a worker thread ends the process with its exit code, not SIGABRT", "[app]") {
  const Ended memory = run_child([] { std::thread([] { throw std::bad_alloc(); }).join(); });
  CHECK(memory.exit_code == kTooLarge);
  CHECK_THAT(memory.stderr_text, Catch::Contains("out of memory"));

  const Ended none = run_child([] { std::terminate(); });
  CHECK(none.exit_code == kSoftware);
  CHECK_THAT(none.stderr_text, Catch::Contains("without an exception"));
}
