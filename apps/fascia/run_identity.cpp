#include "run_identity.hpp"

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace fascia::app {

const std::string& build_identity() {
  static const std::string identity = [] {
    // FNV-1a, 64 bits: a fingerprint of the executable (not a defence against tampering).
    std::uint64_t h = 14695981039346656037ull;
    std::ifstream in("/proc/self/exe", std::ios::binary);
    char buffer[1 << 16];
    while (in.read(buffer, sizeof buffer) || in.gcount() > 0) {
      const std::streamsize n = in.gcount();
      for (std::streamsize i = 0; i < n; ++i) {
        h ^= static_cast<unsigned char>(buffer[i]);
        h *= 1099511628211ull;
      }
      if (n < static_cast<std::streamsize>(sizeof buffer)) break;
    }
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
    return std::string("fascia " FASCIA_VERSION ", executable fnv1a64:") + hex;
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
