#include "unexpected_error.hpp"

#include "exit_code.hpp"
#include "integrate/simulation.hpp"

#include <cxxabi.h>
#include <unistd.h>

#include <cstdlib>
#include <iostream>
#include <memory>
#include <new>
#include <typeinfo>

namespace fascia::app {
namespace {

std::string type_name(const std::type_info& type) {
  int status = 0;
  std::unique_ptr<char, void (*)(void*)> demangled(abi::__cxa_demangle(type.name(), nullptr, nullptr, &status),
                                                   std::free);
  return status == 0 && demangled ? std::string(demangled.get()) : std::string(type.name());
}

std::string internal_error(const std::string& what) {
  return "fascia: internal error: " + what +
         "; no input should lead here: please report it with the scene and the command line";
}

[[noreturn]] void terminate_handler() {
  const std::exception_ptr error = std::current_exception();
  const Failure failure = error ? classify_unexpected(error)
                                : Failure{kSoftware, internal_error("std::terminate called without an exception")};
  std::cerr << failure.message << std::endl;
  _exit(failure.exit_code);
}

}  // namespace

Failure classify_unexpected(std::exception_ptr error) {
  try {
    std::rethrow_exception(error);
  } catch (const SolverError& e) {
    return {kSolverFailed, std::string("fascia: error: ") + e.what()};
  } catch (const std::bad_alloc&) {
    return {kTooLarge,
            "fascia: error: out of memory (an allocation failed beyond what --max-memory estimated); lower the "
            "resolution, or run with more memory (a larger machine or job allocation)"};
  } catch (const std::exception& e) {
    return {kSoftware, internal_error(type_name(typeid(e)) + ": " + e.what())};
  } catch (...) {
    const std::type_info* type = abi::__cxa_current_exception_type();
    return {kSoftware, internal_error("an exception of type " + (type ? type_name(*type) : std::string("unknown")))};
  }
}

void install_terminate_handler() { std::set_terminate(terminate_handler); }

}  // namespace fascia::app
