// Mutation fuzz of what `fascia check` does (parse, validate, estimate, discretise): the shipped
// scenes and the bad-scene catalogue, mutated by a seeded generator, must each end as a valid
// scene or as a SceneError with a documented exit code whose first message has file:line:col;
// any other exception (std::bad_alloc, std::logic_error, ...) fails, a crash or a hang fails the
// run. Deterministic: the same FASCIA_FUZZ_SEED gives the same mutations. CI runs a few hundred
// mutations (seconds); developers run more with FASCIA_FUZZ_RUNS, e.g.
//   FASCIA_FUZZ_RUNS=20000 FASCIA_FUZZ_SEED=7 build/bin/fascia_tests "[fuzz]"
// and replay from run N on with FASCIA_FUZZ_FIRST=N (a failure prints its run and scene).
#include "dsl/build_scene.hpp"
#include "dsl/scene_spec.hpp"
#include "support/mutator.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using namespace fascia::dsl;
using namespace fascia::test;

namespace {

struct Seed {
  std::string path;  // relative to the source tree, so that relative mesh paths resolve
  std::string text;
};

std::vector<Seed> seeds() {
  std::vector<Seed> out;
  for (const char* dir : {"scenes", "tests/dsl/bad_scenes"}) {
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(fs::path(FASCIA_SOURCE_DIR) / dir))
      if (entry.path().extension() == ".yaml") files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    for (const fs::path& f : files) {
      std::ifstream in(f, std::ios::binary);
      std::ostringstream text;
      text << in.rdbuf();
      out.push_back({(fs::path(dir) / f.filename()).string(), text.str()});
    }
  }
  return out;
}

}  // namespace

TEST_CASE("mutated scenes end valid or with a located error and a documented exit code", "[dsl][fuzz]") {
  fs::current_path(FASCIA_SOURCE_DIR);
  const std::vector<Seed> corpus = seeds();
  REQUIRE(corpus.size() > 40);
  // 300 mutations take a few seconds: most fail in validation, the valid ones are discretised
  // under a 64 MiB limit (the shipped scenes need less than 10 MiB).
  const std::uint64_t runs = env_or("FASCIA_FUZZ_RUNS", 300);
  Draw draw(env_or("FASCIA_FUZZ_SEED", 20261124));
  ResourceLimits limits;
  limits.max_memory = 64.0 * 1024 * 1024;
  int valid = 0, refused = 0;
  for (std::uint64_t run = 0; run < runs; ++run) {
    const Seed& seed = draw.pick(corpus);
    const std::string text = mutate(seed.text, draw);
    if (run < env_or("FASCIA_FUZZ_FIRST", 0)) continue;  // reproduce one run: the same draws before it
    if (std::getenv("FASCIA_FUZZ_DUMP")) std::ofstream(std::getenv("FASCIA_FUZZ_DUMP"), std::ios::binary) << text;
    INFO("run " << run << ", mutation of " << seed.path << ":\n" << text.substr(0, 2000));
    try {
      const SceneSpec spec = parse_scene_text(text, seed.path);
      build_scene(spec, limits);
      ++valid;
    } catch (const SceneError& error) {
      ++refused;
      const Diagnostic first = error.diagnostics().sorted().front();
      INFO("first diagnostic: " << first.str());
      const int code = static_cast<int>(error.exit_code());
      const bool documented = code == 65 || code == 66 || code == 71 || code == 74 || code == 78;
      REQUIRE(documented);
      REQUIRE(!first.where.file.empty());
      REQUIRE(first.where.line >= 1);
      REQUIRE(first.where.column >= 1);
    } catch (const std::exception& e) {
      FAIL("escaped exception: " << e.what());
    }
  }
  // Both outcomes occur: the mutations neither all break the scenes nor leave them all intact.
  CHECK(valid > 0);
  CHECK(refused > 0);
}
