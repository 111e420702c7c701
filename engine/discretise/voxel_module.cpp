#include "discretise/voxel_module.hpp"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>
#include <system_error>

namespace fascia {

namespace {

constexpr const char* kModuleFile = "libfascia_openvdb.so";

// FASCIA_MODULE_DIR/libfascia_openvdb.so, else ../lib/libfascia_openvdb.so from the executable.
std::filesystem::path module_path() {
  if (const char* dir = std::getenv("FASCIA_MODULE_DIR"); dir && *dir) return std::filesystem::path(dir) / kModuleFile;
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return kModuleFile;  // the loader's search path
  return exe.parent_path().parent_path() / "lib" / kModuleFile;
}

const VoxelModule* load() {
  const std::filesystem::path path = module_path();
  // RTLD_NOW: a missing symbol is reported here, not at a later call.
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle)
    throw std::runtime_error("cannot load the voxelisation module " + path.string() + ": " + dlerror() +
                             " (it is built with fascia into lib/ next to bin/; FASCIA_MODULE_DIR names another folder)");
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
