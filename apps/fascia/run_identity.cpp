#include "run_identity.hpp"

#include "core/fnv1a.hpp"
#include "discretise/voxel_module.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

namespace fascia::app {

namespace {

// A 64-bit FNV-1a-style fingerprint of a file over its 8-byte words (the last word zero-padded):
// a checkpoint is resumed only by the build that wrote it (not a defence against tampering). Word
// by word it reads a 16 MB program in a few milliseconds.
std::string file_fingerprint(const std::string& path) {
  std::uint64_t h = kFnv1aOffset;
  std::ifstream in(path, std::ios::binary);
  std::vector<char> buffer(1 << 16);
  std::uint64_t bytes = 0;
  while (in.read(buffer.data(), static_cast<std::streamsize>(buffer.size())) || in.gcount() > 0) {
    const std::size_t n = static_cast<std::size_t>(in.gcount());
    bytes += n;
    for (std::size_t i = 0; i < n; i += 8) {
      std::uint64_t word = 0;
      std::memcpy(&word, buffer.data() + i, std::min<std::size_t>(8, n - i));
      h = fnv1a_step(h, word);
    }
    if (n < buffer.size()) break;
  }
  h = fnv1a_step(h, bytes);
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return std::string("fnv1a64w:") + hex;
}

}  // namespace

const std::string& build_identity() {
  static const std::string identity = [] {
    std::string id = "fascia " FASCIA_VERSION ", executable " + file_fingerprint("/proc/self/exe");
    const std::filesystem::path module = voxel_module_file();
    if (!module.empty()) id += ", voxel module " + file_fingerprint(module.string());
    return id;
  }();
  return identity;
}

std::string scene_identity(const dsl::SceneSpec& spec) {
  dsl::Value resolved = spec.resolved;
  for (auto& [key, value] : resolved.fields) {
    if (key != "output") continue;
    std::vector<std::pair<std::string, dsl::Value>> kept;
    for (auto& field : value.fields)
      if (field.first != "file" && field.first != "checkpoint") kept.push_back(field);
    value.fields = kept;
  }
  return dsl::to_yaml(resolved);
}

std::string first_difference(const std::string& here, const std::string& stored) {
  if (here == stored) return "";
  std::istringstream a(here), b(stored);
  std::string la, lb;
  for (int line = 1;; ++line) {
    const bool more_a = static_cast<bool>(std::getline(a, la));
    const bool more_b = static_cast<bool>(std::getline(b, lb));
    if (!more_a && !more_b) return "the texts differ in their line endings";
    if (!more_a) la = "(nothing)";
    if (!more_b) lb = "(nothing)";
    if (la != lb || !more_a || !more_b)
      return "line " + std::to_string(line) + " of the resolved scene: '" + la + "' here, '" + lb + "' in the checkpoint";
  }
}

}  // namespace fascia::app
