// A request to stop the computation, set asynchronously (a signal handler, a wall-clock alarm)
// and polled by long-running loops: each Newton iteration, each line-search trial and each
// iteration of the linear solver. The polls make a stop take effect within one force or
// tangent-product evaluation (or one sparse factorisation), not one whole step.
//
// A poll that finds a request throws StopRequested; the step in progress is abandoned and the
// simulation keeps its last completed step (integrate/simulation.hpp).
#pragma once

#include <atomic>
#include <stdexcept>
#include <string>

namespace fascia {

namespace detail {
// 0: no request; otherwise the reason (a signal number, or a negative code of the caller's).
inline std::atomic<int> g_stop_reason{0};
static_assert(std::atomic<int>::is_always_lock_free, "the stop request must be async-signal-safe");
}  // namespace detail

// Async-signal-safe: a lock-free atomic store. The first reason stays.
inline void request_stop(int reason) noexcept {
  int none = 0;
  detail::g_stop_reason.compare_exchange_strong(none, reason);
}

// The pending reason, 0 when none.
inline int stop_requested() noexcept { return detail::g_stop_reason.load(std::memory_order_relaxed); }

inline void clear_stop_request() noexcept { detail::g_stop_reason.store(0); }

class StopRequested : public std::runtime_error {
 public:
  explicit StopRequested(int reason) : std::runtime_error("stop requested"), m_reason(reason) {}
  int reason() const { return m_reason; }

 private:
  int m_reason;
};

// The poll of the loops named above.
inline void throw_if_stop_requested() {
  if (const int reason = stop_requested()) throw StopRequested(reason);
}

}  // namespace fascia
