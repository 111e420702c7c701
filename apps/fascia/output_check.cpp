#include "output_check.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <limits>

namespace fascia::app {

namespace fs = std::filesystem;

std::string output_path_problem(const std::string& path) {
  std::error_code ec;
  const fs::path p(path);
  if (fs::is_directory(p, ec)) return "'" + path + "' is a directory";
  const fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  if (!fs::is_directory(dir, ec)) return "'" + dir.string() + "': " + std::strerror(ENOENT);
  // The file is written in place and the sidecar through a temporary beside it: both need the
  // folder (and an existing file) writable.
  if (access(dir.c_str(), W_OK) != 0) return "'" + dir.string() + "': " + std::strerror(errno);
  if (fs::exists(p, ec) && access(p.c_str(), W_OK) != 0) return "'" + path + "': " + std::strerror(errno);
  return "";
}

long long output_rows(long long steps, int every) { return 2 + (steps + every - 1) / every; }

void check_output_space(const std::string& path, const dsl::SceneSpec& spec, const dsl::BuiltScene& built,
                        dsl::Diagnostics& diagnostics) {
  const dsl::Location where = spec.run.steps      ? spec.run.steps->where
                              : spec.run.duration ? spec.run.duration->where
                                                  : spec.run.where;
  const long long rows = output_rows(built.steps, spec.output.every);
  if (rows > std::numeric_limits<int>::max()) {
    diagnostics.error(where, std::to_string(built.steps) + " steps written every " + std::to_string(spec.output.every) +
                                 " need " + std::to_string(rows) + " output rows, more than the " +
                                 std::to_string(std::numeric_limits<int>::max()) +
                                 " a file indexes; raise output.every or take fewer steps",
                      dsl::ExitCode::too_large);
    return;
  }
  // Bytes per row: a frame's position, orientation and kinematic fields (io/sample_fields.hpp: 25
  // doubles), a sample's or a surface vertex's position, displacement and velocity (9 doubles) and
  // strain and stress measures (40 floats at most), and a few dozen observables, steps and times.
  constexpr double kFrameBytes = 25 * 8, kPointBytes = 9 * 8 + 40 * 4;
  double bytes = kFrameBytes * built.stats.frames + (spec.output.samples ? kPointBytes * built.stats.samples : 0.0) + 800;
  for (const dsl::BuiltObject& o : built.objects) bytes += kPointBytes * static_cast<double>(o.surface.vertex_frames.size());
  const double need = dsl::output_bytes(static_cast<double>(rows), bytes);
  const double free = dsl::free_disk_bytes(path);
  if (free >= 0 && need > free)
    diagnostics.error(where, "the output '" + path + "' needs about " + bytes_text(need) + " for " +
                                 std::to_string(rows) + " rows (" + std::to_string(built.steps) + " steps, every " +
                                 std::to_string(spec.output.every) + "), and its file system has " +
                                 bytes_text(free) + " free; raise output.every, take fewer steps or write elsewhere (-o)",
                      dsl::ExitCode::too_large);
}

}  // namespace fascia::app
