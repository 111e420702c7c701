#include "solve/blas_core.hpp"

#include <dlfcn.h>

#include <cstdlib>
#include <optional>

namespace fascia {
namespace {

struct OpenBlas {
  const char* (*corename)() = nullptr;
  void (*quit)() = nullptr;
  void (*init)() = nullptr;
};

// OpenBLAS's entry points in the process (null where another BLAS is loaded).
const OpenBlas& openblas() {
  static const OpenBlas api = [] {
    OpenBlas o;
    o.corename = reinterpret_cast<const char* (*)()>(dlsym(RTLD_DEFAULT, "openblas_get_corename"));
    o.quit = reinterpret_cast<void (*)()>(dlsym(RTLD_DEFAULT, "gotoblas_dynamic_quit"));
    o.init = reinterpret_cast<void (*)()>(dlsym(RTLD_DEFAULT, "gotoblas_dynamic_init"));
    if (!o.corename || !o.quit || !o.init) o = OpenBlas{};
    return o;
  }();
  return api;
}

}  // namespace

std::string better_blas_core(const std::string& current, bool avx512, bool avx2_fma) {
  if (current != "Prescott") return {};
  if (avx512) return "SkylakeX";
  if (avx2_fma) return "Haswell";
  return {};
}

std::string blas_core() {
  const OpenBlas& o = openblas();
  const char* name = o.corename ? o.corename() : nullptr;
  return name ? name : "";
}

bool set_blas_core(const std::string& name) {
  const OpenBlas& o = openblas();
  if (!o.init) return false;
  // gotoblas_dynamic_init reads OPENBLAS_CORETYPE once a quit has cleared the selected kernels.
  const char* user = std::getenv("OPENBLAS_CORETYPE");
  const std::optional<std::string> previous = user ? std::optional<std::string>(user) : std::nullopt;
  setenv("OPENBLAS_CORETYPE", name.c_str(), 1);
  o.quit();
  o.init();
  if (previous)
    setenv("OPENBLAS_CORETYPE", previous->c_str(), 1);
  else
    unsetenv("OPENBLAS_CORETYPE");
  return true;
}

std::string select_blas_core() {
  if (std::getenv("OPENBLAS_CORETYPE")) return {};
  __builtin_cpu_init();
  const bool avx512 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                      __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512dq") &&
                      __builtin_cpu_supports("avx512cd");
  const bool avx2_fma = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  const std::string core = better_blas_core(blas_core(), avx512, avx2_fma);
  if (core.empty() || !set_blas_core(core)) return {};
  return core;
}

}  // namespace fascia
