#include "progress.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>

namespace fascia::app {

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--:--";
  const long s = static_cast<long>(std::lround(seconds));
  char buffer[32];
  if (s >= 3600)
    std::snprintf(buffer, sizeof buffer, "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  else
    std::snprintf(buffer, sizeof buffer, "%02ld:%02ld", s / 60, s % 60);
  return buffer;
}

Progress::Mode Progress::mode_for(bool quiet) {
  if (quiet) return Mode::quiet;
  return isatty(STDERR_FILENO) ? Mode::bar : Mode::log;
}

Progress::Progress(Mode mode, double log_interval_seconds)
    : m_mode(mode), m_interval(log_interval_seconds), m_start(std::chrono::steady_clock::now()), m_last_print(m_start) {}

std::string Progress::line(const ProgressFigures& f, bool bar) const {
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
  const double eta = f.step > 0 ? elapsed / f.step * (f.total - f.step) : NAN;
  std::ostringstream os;
  if (bar) {
    const int width = 24;
    const int filled = f.total > 0 ? static_cast<int>(width * static_cast<double>(f.step) / f.total) : 0;
    os << "[" << std::string(static_cast<std::size_t>(filled), '#')
       << std::string(static_cast<std::size_t>(width - filled), '.') << "] ";
  }
  char t[32];
  std::snprintf(t, sizeof t, "%.4g", f.time);
  char r[32];
  std::snprintf(r, sizeof r, "%.2e", f.residual);
  os << "step " << f.step << "/" << f.total << "  t " << t << " s  newton " << f.newton << "  cg " << f.cg
     << "  residual " << r << "  elapsed " << format_duration(elapsed) << "  ETA "
     << (f.step >= f.total ? std::string("00:00") : format_duration(eta));
  return os.str();
}

void Progress::update(const ProgressFigures& figures) {
  if (m_mode == Mode::quiet) return;
  const auto now = std::chrono::steady_clock::now();
  if (m_mode == Mode::bar) {
    // Redraw at most ~10 times a second.
    if (m_printed && std::chrono::duration<double>(now - m_last_print).count() < 0.1) return;
    std::cerr << "\r" << line(figures, true) << "\x1b[K" << std::flush;
  } else {
    if (std::chrono::duration<double>(now - m_last_print).count() < m_interval) return;
    std::cerr << "fascia: " << line(figures, false) << std::endl;
  }
  m_last_print = now;
  m_printed = true;
}

void Progress::finish(const ProgressFigures& figures, const std::string& status) {
  if (m_mode == Mode::quiet) return;
  if (m_mode == Mode::bar) {
    std::cerr << "\r" << line(figures, true) << "\x1b[K\n";
  }
  std::cerr << "fascia: " << status << ": " << line(figures, false) << std::endl;
}

}  // namespace fascia::app
