#include "discretise/voxel_module.hpp"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

namespace fascia {

namespace {

constexpr const char* kModuleFile = "libfascia_openvdb.so";

// dlopen's flags. RTLD_NOW: a missing symbol is reported at the load, not at a later call.
// RTLD_DEEPBIND: the module's and OpenVDB's libraries look their symbols up in their own scope
// before the program's (about 70,000 relocations, most against OpenVDB's own symbols, each of
// which would first miss in the program's 60-odd libraries): a voxelising command starts about
// 45 ms sooner on a 2-core VM. The sanitizers' runtimes refuse RTLD_DEEPBIND (their interceptors
// must see every call), so their builds load without it.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define FASCIA_SANITIZED_BUILD
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define FASCIA_SANITIZED_BUILD
#endif
#endif
#ifdef FASCIA_SANITIZED_BUILD
constexpr int kLoadFlags = RTLD_NOW | RTLD_LOCAL;
#else
constexpr int kLoadFlags = RTLD_NOW | RTLD_LOCAL | RTLD_DEEPBIND;
#endif

// Where the module is looked for, in order: FASCIA_MODULE_DIR; ../lib from the executable (a
// build tree's or a bundle's bin/ and lib/); the build tree's lib/ (a program copied elsewhere on
// the machine that built it).
std::vector<std::filesystem::path> module_paths() {
  std::vector<std::filesystem::path> paths;
  if (const char* dir = std::getenv("FASCIA_MODULE_DIR"); dir && *dir) {
    paths.push_back(std::filesystem::path(dir) / kModuleFile);
    return paths;
  }
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) paths.push_back(exe.parent_path().parent_path() / "lib" / kModuleFile);
  paths.push_back(std::filesystem::path(FASCIA_MODULE_BUILD_DIR) / kModuleFile);
  return paths;
}

}  // namespace

std::filesystem::path voxel_module_file() {
  for (const std::filesystem::path& path : module_paths()) {
    std::error_code ec;
    if (std::filesystem::is_regular_file(path, ec)) return path;
  }
  return {};
}

namespace {

const VoxelModule* load() {
  const std::filesystem::path path = voxel_module_file();
  if (path.empty()) {
    std::string tried;
    for (const std::filesystem::path& p : module_paths()) tried += (tried.empty() ? "" : ", ") + p.string();
    throw std::runtime_error("cannot find the voxelisation module " + std::string(kModuleFile) + " (looked for " +
                             tried + "; it is built with fascia into lib/ next to bin/, and FASCIA_MODULE_DIR names "
                             "another folder)");
  }
  void* handle = dlopen(path.c_str(), kLoadFlags);
  if (!handle) throw std::runtime_error("cannot load the voxelisation module " + path.string() + ": " + dlerror());
  using Entry = const VoxelModule* (*)();
  const auto entry = reinterpret_cast<Entry>(dlsym(handle, "fascia_voxel_module"));
  if (!entry) throw std::runtime_error("the voxelisation module " + path.string() + " has no entry point: " + dlerror());
  return entry();  // the module stays loaded for the life of the process
}

}  // namespace

const VoxelModule& voxel_module() {
  static std::once_flag once;
  static const VoxelModule* module = nullptr;
  std::call_once(once, [] { module = load(); });
  return *module;
}

}  // namespace fascia
