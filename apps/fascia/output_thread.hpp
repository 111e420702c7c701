// A run's output work (its rows, checkpoints and sidecars) in the order it is submitted, on a
// thread of its own or on the caller's.
//
// On its own thread a row is computed and written while the next steps run: with the whole step
// on the device the host is otherwise idle during a step, and a row of the pelvis at 56 k samples
// (fields of every sample, about 20 MB) takes about as long as a step that reuses its
// factorisation.
//
// Jobs run one at a time and in order, so the HDF5 library is never entered from two threads at
// once and a file's writes keep the order a killed run's readability relies on (io/trajectory.cpp,
// io/checkpoint.hpp). At most kQueuedJobs jobs are submitted and not yet finished: submit() waits
// while that many are, so the steps run at most that many rows ahead of the file, and the rows
// catch up during the steps that factorise. An exception a job throws is rethrown on the caller's
// thread by the next submit() or by finish(); the jobs queued after the failed one, and the one
// given to that call, do not run.
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
  // Jobs submitted and not finished at most (queued or running). Each holds a copy of a step's
  // state (frames only, about 0.1 MB at 56 k samples); four let the rows of the steps between two
  // factorisations catch up during the next one.
  static constexpr int kQueuedJobs = 4;

  // background: jobs run on a thread of this object's, whose OpenMP parallel regions use
  // `threads` threads; otherwise each runs inside submit().
  OutputThread(bool background, int threads);
  ~OutputThread();  // runs the jobs still queued; an exception one throws is dropped
  OutputThread(const OutputThread&) = delete;
  OutputThread& operator=(const OutputThread&) = delete;

  // Rethrows a failed job's exception, if any (and drops `job`); otherwise waits while
  // kQueuedJobs jobs are unfinished, then queues `job`.
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
  std::thread m_thread;
};

}  // namespace fascia::app
