// The bad-scene catalogue: every file in tests/dsl/bad_scenes/ starts with
//   # set: path=value          (optional, repeatable: --set overrides)
//   # expect: LOCATION EXIT MESSAGE
// where LOCATION is line:col in the file itself, FILE:line:col (relative to bad_scenes/) or
// --set:k:col, EXIT the sysexits code and MESSAGE a substring of the first diagnostic.
#include "dsl/build_scene.hpp"
#include "dsl/scene_spec.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using namespace fascia::dsl;

namespace {

struct Expectation {
  std::vector<std::string> sets;
  std::string location;
  int exit_code = -1;
  std::string message;
};

Expectation read_expectation(const fs::path& file) {
  Expectation e;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line) && line.rfind("#", 0) == 0) {
    if (line.rfind("# set: ", 0) == 0) e.sets.push_back(line.substr(7));
    if (line.rfind("# expect: ", 0) == 0) {
      std::istringstream ss(line.substr(10));
      ss >> e.location >> e.exit_code;
      std::getline(ss, e.message);
      e.message.erase(0, e.message.find_first_not_of(' '));
    }
  }
  return e;
}

}  // namespace

TEST_CASE("bad scenes report their first problem at the expected place with the expected exit code", "[dsl]") {
  const fs::path dir = fs::path(FASCIA_SOURCE_DIR) / "tests/dsl/bad_scenes";
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.path().extension() == ".yaml") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  REQUIRE(files.size() >= 30);

  for (const fs::path& file : files) {
    DYNAMIC_SECTION(file.filename().string()) {
      const Expectation e = read_expectation(file);
      REQUIRE(e.exit_code > 0);
      const std::string path = (fs::path("tests/dsl/bad_scenes") / file.filename()).string();
      // Scenes are addressed relative to the source tree so that messages are short and stable.
      fs::current_path(FASCIA_SOURCE_DIR);
      std::string expected_location;
      if (e.location.rfind("--set:", 0) == 0)
        expected_location = e.location;
      else if (e.location.find(".yaml:") != std::string::npos)
        expected_location = "tests/dsl/bad_scenes/" + e.location;
      else
        expected_location = path + ":" + e.location;

      bool threw = false;
      try {
        const SceneSpec spec = parse_scene(path, e.sets);
        build_scene(spec);
      } catch (const SceneError& error) {
        threw = true;
        const Diagnostic first = error.diagnostics().sorted().front();
        INFO("all diagnostics:\n" << error.diagnostics().str());
        CHECK(first.where.str() == expected_location);
        CHECK(static_cast<int>(first.code) == e.exit_code);
        CHECK_THAT(first.message, Catch::Contains(e.message));
      }
      CHECK(threw);
    }
  }
}
