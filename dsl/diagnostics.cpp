#include "dsl/diagnostics.hpp"

#include <algorithm>
#include <tuple>

namespace fascia::dsl {

std::string Location::str() const {
  std::string s = file.empty() ? "<scene>" : file;
  if (line > 0) s += ":" + std::to_string(line);
  if (line > 0 && column > 0) s += ":" + std::to_string(column);
  return s;
}

bool operator<(const Location& a, const Location& b) {
  return std::tie(a.file, a.line, a.column) < std::tie(b.file, b.line, b.column);
}

void Diagnostics::error(const Location& where, std::string message, ExitCode code) {
  m_items.push_back({where, std::move(message), code});
}

std::vector<Diagnostic> Diagnostics::sorted() const {
  std::vector<Diagnostic> out = m_items;
  std::stable_sort(out.begin(), out.end(), [](const Diagnostic& a, const Diagnostic& b) { return a.where < b.where; });
  // The same problem reached twice (e.g. through an include) is reported once.
  out.erase(std::unique(out.begin(), out.end(),
                        [](const Diagnostic& a, const Diagnostic& b) {
                          return !(a.where < b.where) && !(b.where < a.where) && a.message == b.message;
                        }),
            out.end());
  return out;
}

ExitCode Diagnostics::exit_code() const {
  if (m_items.empty()) return ExitCode::ok;
  if (has(ExitCode::too_large)) return ExitCode::too_large;
  return sorted().front().code;
}

bool Diagnostics::has(ExitCode code) const {
  for (const Diagnostic& d : m_items)
    if (d.code == code) return true;
  return false;
}

std::string Diagnostics::str() const {
  std::string s;
  for (const Diagnostic& d : sorted()) s += d.str() + "\n";
  return s;
}

SceneError::SceneError(Diagnostics diagnostics)
    : std::runtime_error(diagnostics.empty() ? std::string("scene error") : diagnostics.sorted().front().str()),
      m_diagnostics(std::move(diagnostics)) {}

namespace {

// Optimal string alignment distance (Levenshtein with adjacent transpositions), case-insensitive.
int edit_distance(const std::string& a, const std::string& b) {
  const std::size_t n = a.size(), m = b.size();
  std::vector<std::vector<int>> d(n + 1, std::vector<int>(m + 1, 0));
  for (std::size_t i = 0; i <= n; ++i) d[i][0] = static_cast<int>(i);
  for (std::size_t j = 0; j <= m; ++j) d[0][j] = static_cast<int>(j);
  auto lower = [](char c) { return static_cast<char>(c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c); };
  for (std::size_t i = 1; i <= n; ++i) {
    for (std::size_t j = 1; j <= m; ++j) {
      const int cost = lower(a[i - 1]) == lower(b[j - 1]) ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && lower(a[i - 1]) == lower(b[j - 2]) && lower(a[i - 2]) == lower(b[j - 1]))
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[n][m];
}

}  // namespace

std::string closest_match(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  int best_distance = 1 << 30;
  for (const std::string& c : candidates) {
    const int dist = edit_distance(word, c);
    if (dist < best_distance) {
      best_distance = dist;
      best = c;
    }
  }
  // Suggest only plausible typos: at most a third of the longer word, and at least 2 allowed.
  const int allowed = std::max<int>(2, static_cast<int>(std::max(word.size(), best.size())) / 3);
  return best_distance <= allowed ? best : std::string();
}

std::string did_you_mean(const std::string& word, const std::vector<std::string>& candidates) {
  const std::string c = closest_match(word, candidates);
  return c.empty() ? std::string() : " (did you mean '" + c + "'?)";
}

}  // namespace fascia::dsl
