// Jobs run in the order they are submitted, one at a time, on a thread of their own or on the
// caller's: a run's output work (apps/fascia/cmd_run.cpp forms its rows on one and makes every
// HDF5 call on another).
//
// At most `depth` jobs are submitted and not yet finished: submit() waits while that many are.
// An exception a job throws is rethrown on the caller's thread by the next submit() or by
// finish(); the jobs queued after the failed one, and the one given to that call, do not run.
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace fascia::app {

class OutputThread {
 public:
  // background: jobs run on a thread of this object's, whose OpenMP parallel regions use
  // `threads` threads, at most `depth` (>= 1) of them submitted and not finished; otherwise each
  // runs inside submit().
  OutputThread(bool background, int threads, int depth);
  ~OutputThread();  // runs the jobs still queued; an exception one throws is dropped
  OutputThread(const OutputThread&) = delete;
  OutputThread& operator=(const OutputThread&) = delete;

  // Rethrows a failed job's exception, if any (and drops `job`); otherwise waits while `depth`
  // jobs are unfinished, then queues `job`.
  void submit(std::function<void()> job);
  // Waits until every job submitted has run, and rethrows a failed one's exception, if any.
  void finish();

 private:
  void serve(int threads);
  // Rethrows and clears a stored exception (lock held).
  void rethrow_error();

  std::mutex m_mutex;
  std::condition_variable m_changed;
  std::deque<std::function<void()>> m_jobs;  // queued, not started (background)
  bool m_running = false;                    // a job is running (background)
  bool m_quit = false;
  std::exception_ptr m_error;
  const int m_depth;
  std::thread m_thread;
};

}  // namespace fascia::app
