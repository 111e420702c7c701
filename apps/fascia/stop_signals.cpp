#include "stop_signals.hpp"

#include "core/stop_request.hpp"
#include "dsl/units.hpp"

#include <sys/time.h>

#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <vector>

namespace fascia::app {

namespace {

std::atomic<bool> g_checkpoint_request{false};
std::atomic<bool> g_hangup{false};
std::atomic<int> g_interrupts{0};

void on_stop(int signal) {
  // A second Ctrl-C means "now": back to the default action, which ends the process.
  if (signal == SIGINT && g_interrupts.fetch_add(1) >= 1) {
    std::signal(SIGINT, SIG_DFL);
    std::raise(SIGINT);
    return;
  }
  request_stop(signal);
}
void on_alarm(int) { request_stop(kMaxWallReason); }
void on_checkpoint(int) { g_checkpoint_request.store(true); }
void on_hangup(int) { g_hangup.store(true); }

void install(int signal, void (*handler)(int)) {
  struct sigaction action {};
  action.sa_handler = handler;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;  // interrupted writes resume: a checkpoint is never cut short
  sigaction(signal, &action, nullptr);
}

}  // namespace

void install_stop_signals() {
  for (int s : {SIGTERM, SIGINT, SIGUSR1, SIGQUIT}) install(s, on_stop);
  install(SIGALRM, on_alarm);
  install(SIGUSR2, on_checkpoint);
  install(SIGHUP, on_hangup);
}

void arm_max_wall(double seconds) {
  itimerval timer{};
  timer.it_value.tv_sec = static_cast<time_t>(seconds);
  timer.it_value.tv_usec = static_cast<suseconds_t>((seconds - std::floor(seconds)) * 1e6);
  if (timer.it_value.tv_sec == 0 && timer.it_value.tv_usec == 0) timer.it_value.tv_usec = 1;
  setitimer(ITIMER_REAL, &timer, nullptr);
}

std::string stop_reason_name(int reason) {
  switch (reason) {
    case kMaxWallReason: return "--max-wall";
    case SIGTERM: return "SIGTERM";
    case SIGINT: return "SIGINT";
    case SIGUSR1: return "SIGUSR1";
    case SIGQUIT: return "SIGQUIT";
    default: return "signal " + std::to_string(reason);
  }
}

bool take_checkpoint_request() { return g_checkpoint_request.exchange(false); }
bool take_hangup() { return g_hangup.exchange(false); }

std::optional<double> parse_duration(const std::string& text) {
  if (text.find(':') != std::string::npos) {
    // [D-]HH:MM:SS or MM:SS, as Slurm prints time limits.
    long days = 0;
    std::string rest = text;
    if (const auto dash = rest.find('-'); dash != std::string::npos) {
      char* end = nullptr;
      days = std::strtol(rest.c_str(), &end, 10);
      if (end != rest.c_str() + dash || days < 0) return std::nullopt;
      rest = rest.substr(dash + 1);
    }
    std::vector<long> parts;
    std::stringstream in(rest);
    for (std::string part; std::getline(in, part, ':');) {
      if (part.empty() || part.find_first_not_of("0123456789") != std::string::npos) return std::nullopt;
      parts.push_back(std::strtol(part.c_str(), nullptr, 10));
    }
    if (parts.size() < 2 || parts.size() > 3) return std::nullopt;
    if (parts.size() == 2) parts.insert(parts.begin(), 0);
    const double seconds = days * 86400.0 + parts[0] * 3600.0 + parts[1] * 60.0 + parts[2];
    return seconds;
  }
  std::string error;
  const std::optional<dsl::Quantity> q = dsl::parse_quantity(text, error);
  if (!q || !(q->value >= 0) || !std::isfinite(q->value)) return std::nullopt;
  if (!q->bare && q->dimension != dsl::dim::time) return std::nullopt;
  return q->value;
}

}  // namespace fascia::app
