// A run's output work (its rows, checkpoints and sidecars) in the order it is submitted, on a
// thread of its own or on the caller's.
//
// On its own thread a row is computed and written while the next step runs: with the whole step
// on the device the host is otherwise idle during a step, and a row of the pelvis at 56 k samples
// (fields of every sample, about 20 MB) takes about half as long as the step.
//
// Jobs run one at a time and in order, so the HDF5 library is never entered from two threads at
// once and a file's writes keep the order a killed run's readability relies on (io/trajectory.cpp,
// io/checkpoint.hpp). At most one job is in flight: submit() first waits for the previous one, so
// the steps never run more than one row ahead of the file. An exception a job throws is rethrown
// on the caller's thread by the next submit() or by finish(); the jobs submitted after a failed
// one do not run.
#pragma once

#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace fascia::app {

class OutputThread {
 public:
  // background: jobs run on a thread of this object's, whose OpenMP parallel regions use
  // `threads` threads; otherwise each runs inside submit().
  OutputThread(bool background, int threads);
  ~OutputThread();  // waits for the job in flight; an exception it threw is dropped
  OutputThread(const OutputThread&) = delete;
  OutputThread& operator=(const OutputThread&) = delete;

  // Waits for the job in flight and rethrows its exception, if any; then starts `job`.
  void submit(std::function<void()> job);
  // Waits for the job in flight and rethrows its exception, if any.
  void finish();

 private:
  void serve(int threads);
  // Waits until no job is in flight (lock held); rethrows and clears a stored exception.
  void wait_idle(std::unique_lock<std::mutex>& lock);

  std::mutex m_mutex;
  std::condition_variable m_changed;
  std::function<void()> m_job;  // the job in flight (background)
  bool m_busy = false;
  bool m_quit = false;
  std::exception_ptr m_error;
  std::thread m_thread;
};

}  // namespace fascia::app
