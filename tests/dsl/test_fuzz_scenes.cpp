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

#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

namespace fs = std::filesystem;
using namespace fascia::dsl;

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

// Uniform integers from one 64-bit Mersenne twister (its sequence is fixed by the standard; the
// standard distributions are not, so they are not used).
class Draw {
 public:
  explicit Draw(std::uint64_t seed) : m_engine(seed) {}
  std::size_t below(std::size_t n) { return n == 0 ? 0 : static_cast<std::size_t>(m_engine() % n); }
  template <class T>
  const T& pick(const std::vector<T>& items) { return items[below(items.size())]; }

 private:
  std::mt19937_64 m_engine;
};

// Positions of number-like tokens (digits with sign, point, exponent).
std::vector<std::pair<std::size_t, std::size_t>> numbers(const std::string& text) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (std::size_t i = 0; i < text.size();) {
    if (std::isdigit(static_cast<unsigned char>(text[i]))) {
      std::size_t j = i;
      while (j < text.size() && (std::isalnum(static_cast<unsigned char>(text[j])) || text[j] == '.' ||
                                 ((text[j] == '-' || text[j] == '+') && (text[j - 1] == 'e'))))
        ++j;
      out.emplace_back(i, j - i);
      i = j;
    } else {
      ++i;
    }
  }
  return out;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::string join(const std::vector<std::string>& lines) {
  std::string s;
  for (const std::string& l : lines) s += l + "\n";
  return s;
}

std::string mutate(std::string text, Draw& draw) {
  static const std::vector<std::string> extremes = {
      "0", "-1", "1e308", "-1e308", "1e-300", "2147483647", "2147483648", "99999999999999999999", "nan", ".inf",
      "1e155", "1e-12", "100000", "0.5", "-0", "1e10 s", "1e308 GPa", "3 km", "1 um", "[]", "{}", "~", "\"7\""};
  static const std::vector<std::string> fragments = {
      "{", "}", "[", "]", ":", ": ", ", ", "- ", "&a ", "*a", "*b", "---\n", "\t", "#", "'", "\"", "? ", "!!str ",
      "<<: *a\n", "include: /dev/zero\n", "include: [a.yaml, a.yaml]\n", "\n  ", "  ", "@", "%YAML 1.2\n",
      std::string(5000, 'x'), "objects: {frames: {box: {min: [0,0,0], max: [1,1,1]}}}\n"};
  static const std::vector<std::string> keys = {
      "materials", "objects",  "young",    "poisson",   "box",     "cells",   "surface", "mesh",   "frame_spacing",
      "sample_spacing", "dt",  "duration", "steps",     "every",   "region",  "fix",     "gravity", "motion",
      "share",     "attach",   "within",   "transform", "scale",   "seed",    "neighbours", "output", "file"};
  const int count = 1 + static_cast<int>(draw.below(3));
  for (int m = 0; m < count; ++m) {
    switch (draw.below(8)) {
      case 0: {  // a number replaced by an extreme value
        const auto spots = numbers(text);
        if (spots.empty()) break;
        const auto [at, length] = draw.pick(spots);
        text.replace(at, length, draw.pick(extremes));
        break;
      }
      case 1: {  // a fragment inserted anywhere
        text.insert(draw.below(text.size() + 1), draw.pick(fragments));
        break;
      }
      case 2: {  // a line deleted, duplicated or two swapped
        std::vector<std::string> lines = lines_of(text);
        if (lines.empty()) break;
        const std::size_t a = draw.below(lines.size()), b = draw.below(lines.size());
        const std::size_t how = draw.below(3);
        if (how == 0) lines.erase(lines.begin() + static_cast<long>(a));
        else if (how == 1) lines.insert(lines.begin() + static_cast<long>(a), lines[b]);
        else std::swap(lines[a], lines[b]);
        text = join(lines);
        break;
      }
      case 3: {  // truncated
        text.resize(draw.below(text.size() + 1));
        break;
      }
      case 4: {  // a byte replaced
        if (text.empty()) break;
        text[draw.below(text.size())] = static_cast<char>(draw.below(256));
        break;
      }
      case 5: {  // a key misspelt or replaced by another
        const std::string& key = draw.pick(keys);
        const std::size_t at = text.find(key + ":");
        if (at == std::string::npos) break;
        text.replace(at, key.size(), draw.below(2) ? draw.pick(keys) : key.substr(0, key.size() - 1));
        break;
      }
      case 6: {  // a unit changed
        static const std::vector<std::pair<std::string, std::string>> units = {
            {"mm", "km"}, {"kPa", "GPa"}, {"ms", "ns"}, {"mm", "um"}, {" s", " ms"}, {"kg/m^3", "g"}};
        const auto& [from, to] = draw.pick(units);
        const std::size_t at = text.find(from, draw.below(text.size() + 1));
        if (at != std::string::npos) text.replace(at, from.size(), to);
        break;
      }
      default: {  // a line indented differently
        std::vector<std::string> lines = lines_of(text);
        if (lines.empty()) break;
        std::string& line = lines[draw.below(lines.size())];
        if (draw.below(2) && line.size() > 1) line.erase(0, 2);
        else line.insert(0, "  ");
        text = join(lines);
        break;
      }
    }
  }
  return text;
}

std::uint64_t env_or(const char* name, std::uint64_t fallback) {
  const char* v = std::getenv(name);
  return v ? std::strtoull(v, nullptr, 10) : fallback;
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
