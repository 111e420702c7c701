// Progress reporting of `fascia run` on stderr: a one-line bar redrawn with '\r' on a terminal, a
// status line every few seconds otherwise (batch logs), nothing with --quiet.
#pragma once

#include <chrono>
#include <string>

namespace fascia::app {

struct ProgressFigures {
  int step = 0;           // steps done
  int total = 0;          // steps planned
  double time = 0;        // simulated time, s
  int newton = 0;         // Newton iterations of the last step
  int cg = 0;             // CG iterations of the last step
  double residual = 0;    // relative residual of the last step
};

class Progress {
 public:
  enum class Mode { bar, log, quiet };

  // mode_for(): bar when stderr is a terminal, log otherwise, quiet when asked.
  static Mode mode_for(bool quiet);

  Progress(Mode mode, double log_interval_seconds = 10.0);
  void update(const ProgressFigures& figures);
  // Final line (log mode) or the completed bar and a newline (bar mode).
  void finish(const ProgressFigures& figures, const std::string& status);

 private:
  std::string line(const ProgressFigures& figures, bool bar) const;

  Mode m_mode;
  double m_interval;
  std::chrono::steady_clock::time_point m_start, m_last_print;
  bool m_printed = false;
};

// "1:02:03", "02:03" for ETAs and elapsed times.
std::string format_duration(double seconds);

}  // namespace fascia::app
