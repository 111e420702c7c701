// A seeded, deterministic text mutator for the fuzz tests (scenes, mesh files): numbers replaced
// by extreme values, fragments of YAML and of file formats inserted, lines deleted, duplicated,
// swapped or re-indented, bytes replaced, keys misspelt, units changed, texts truncated.
#pragma once

#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace fascia::test {

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
inline std::vector<std::pair<std::size_t, std::size_t>> numbers(const std::string& text) {
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

inline std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

inline std::string join(const std::vector<std::string>& lines) {
  std::string s;
  for (const std::string& l : lines) s += l + "\n";
  return s;
}

inline std::string mutate(std::string text, Draw& draw) {
  static const std::vector<std::string> extremes = {
      "0", "-1", "1e308", "-1e308", "1e-300", "2147483647", "2147483648", "99999999999999999999", "nan", ".inf",
      "1e155", "1e-12", "100000", "0.5", "-0", "1e10 s", "1e308 GPa", "3 km", "1 um", "[]", "{}", "~", "\"7\""};
  static const std::vector<std::string> fragments = {
      "{", "}", "[", "]", ":", ": ", ", ", "- ", "&a ", "*a", "*b", "---\n", "\t", "#", "'", "\"", "? ", "!!str ",
      "<<: *a\n", "include: /dev/zero\n", "include: [a.yaml, a.yaml]\n", "\n  ", "  ", "@", "%YAML 1.2\n",
      std::string(5000, 'x'), "objects: {frames: {box: {min: [0,0,0], max: [1,1,1]}}}\n",
      // mesh formats: legacy VTK, Gmsh, OBJ, STL
      "POINTS 2000000000 double\n", "CELLS 3 12\n", "CELL_TYPES 1\n99\n", "$Nodes\n", "$Elements\n999999999\n",
      "v nan 0 0\n", "v 1e308 -1e308 1e308\n", "f 1 2 99999\n", "f -1 -2 -3\n", "f 1\n", "facet normal 0 0 1\n",
      "endsolid\n"};
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

// An unsigned integer from the environment, or `fallback`.
inline std::uint64_t env_or(const char* name, std::uint64_t fallback) {
  const char* v = std::getenv(name);
  return v ? std::strtoull(v, nullptr, 10) : fallback;
}

}  // namespace fascia::test
