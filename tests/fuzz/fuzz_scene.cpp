// libFuzzer target: the scene language (YAML parse, include/extends, --set, validation and
// cross-checks; dsl::parse_scene_text). A scene ends valid or with a SceneError of a documented
// exit code whose first diagnostic has file:line:col; anything else is a finding. Relative paths
// resolve from the source tree's tests/dsl/bad_scenes, so includes and meshes of the corpus load.
#include "dsl/diagnostics.hpp"
#include "dsl/scene_spec.hpp"
#include "fuzz_input.hpp"

#include <filesystem>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace fascia::dsl;
  static const bool in_source_tree = [] {
    std::filesystem::current_path(FASCIA_SOURCE_DIR);
    return true;
  }();
  (void)in_source_tree;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    parse_scene_text(text, "tests/dsl/bad_scenes/fuzz.yaml");
  } catch (const SceneError& error) {
    const int code = static_cast<int>(error.exit_code());
    if (code != 65 && code != 66 && code != 71 && code != 74 && code != 78)
      fascia::fuzz::finding("undocumented exit code " + std::to_string(code) + ": " + error.what());
    const Diagnostic first = error.diagnostics().sorted().front();
    if (first.where.file.empty() || first.where.line < 1 || first.where.column < 1)
      fascia::fuzz::finding("a diagnostic without file:line:col: " + first.str());
  } catch (const std::exception& e) {
    fascia::fuzz::finding(std::string("escaped exception: ") + e.what());
  }
  return 0;
}
