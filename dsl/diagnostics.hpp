// Error reporting for the scene language: every problem found in a scene is collected with its
// source position and reported at once, sorted by position, as `file:line:col: message`.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace fascia::dsl {

// A position in a source text. Lines and columns count from 1; line 0 means "the whole file".
// Command-line overrides use the file name "--set", line k for the k-th --set argument.
struct Location {
  std::string file;
  int line = 0;
  int column = 0;

  std::string str() const;  // "file:line:col", "file:line" or "file"
};

bool operator<(const Location& a, const Location& b);

// Exit codes of DESIGN.md (sysexits) that scene problems map to.
enum class ExitCode : int {
  ok = 0,
  solver_failed = 1,
  usage = 64,
  bad_data = 65,       // a mesh or output file exists but cannot be parsed
  missing_input = 66,  // a scene, include or mesh file does not exist or cannot be read
  too_large = 71,      // the scene asks for more than a limit allows (memory, disk, input size)
  io_error = 74,
  stopped = 75,
  bad_scene = 78,
};

struct Diagnostic {
  Location where;
  std::string message;
  ExitCode code = ExitCode::bad_scene;

  std::string str() const { return where.str() + ": " + message; }
};

// Collects diagnostics; sorted() orders them by file, line, column (stable for equal positions).
class Diagnostics {
 public:
  void error(const Location& where, std::string message, ExitCode code = ExitCode::bad_scene);
  bool empty() const { return m_items.empty(); }
  std::size_t size() const { return m_items.size(); }
  std::vector<Diagnostic> sorted() const;
  // Exit code of the first diagnostic in sorted order (DESIGN.md codes); ok when empty. A
  // refusal for size (too_large) wins over the others: what follows it was not examined.
  ExitCode exit_code() const;
  bool has(ExitCode code) const;
  // All diagnostics, one per line, sorted.
  std::string str() const;

 private:
  std::vector<Diagnostic> m_items;
};

// Thrown by the parser and the scene builder when a scene has problems; carries all of them.
class SceneError : public std::runtime_error {
 public:
  explicit SceneError(Diagnostics diagnostics);
  const Diagnostics& diagnostics() const { return m_diagnostics; }
  ExitCode exit_code() const { return m_diagnostics.exit_code(); }

 private:
  Diagnostics m_diagnostics;
};

// Closest candidate to `word` by edit distance, or "" when none is close enough to suggest.
std::string closest_match(const std::string& word, const std::vector<std::string>& candidates);

// " (did you mean 'x'?)" or "".
std::string did_you_mean(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace fascia::dsl
