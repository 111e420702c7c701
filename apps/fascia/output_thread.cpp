#include "output_thread.hpp"

#include <omp.h>

#include <utility>

namespace fascia::app {

OutputThread::OutputThread(bool background, int threads, int depth) : m_depth(depth < 1 ? 1 : depth) {
  if (background) m_thread = std::thread([this, threads] { serve(threads); });
}

OutputThread::~OutputThread() {
  if (!m_thread.joinable()) return;
  {
    const std::lock_guard<std::mutex> lock(m_mutex);
    m_quit = true;
  }
  m_changed.notify_all();
  m_thread.join();
}

void OutputThread::rethrow_error() {
  if (m_error) std::rethrow_exception(std::exchange(m_error, nullptr));
}

void OutputThread::submit(std::function<void()> job) {
  std::unique_lock<std::mutex> lock(m_mutex);
  if (!m_thread.joinable()) {
    lock.unlock();
    job();
    return;
  }
  m_changed.wait(lock, [this] {
    return m_error || static_cast<int>(m_jobs.size()) + (m_running ? 1 : 0) < m_depth;
  });
  rethrow_error();
  m_jobs.push_back(std::move(job));
  lock.unlock();
  m_changed.notify_all();
}

void OutputThread::finish() {
  std::unique_lock<std::mutex> lock(m_mutex);
  m_changed.wait(lock, [this] { return m_jobs.empty() && !m_running; });
  rethrow_error();
}

void OutputThread::serve(int threads) {
  // A new thread starts from the process's initial OpenMP settings, not the caller's.
  omp_set_num_threads(threads);
  std::unique_lock<std::mutex> lock(m_mutex);
  for (;;) {
    m_changed.wait(lock, [this] { return !m_jobs.empty() || m_quit; });
    if (m_jobs.empty()) return;  // quit, nothing queued
    std::function<void()> job = std::move(m_jobs.front());
    m_jobs.pop_front();
    m_running = true;
    lock.unlock();
    std::exception_ptr error;
    try {
      job();
    } catch (...) {
      error = std::current_exception();
    }
    lock.lock();
    m_running = false;
    if (error) {
      m_error = error;
      m_jobs.clear();  // what follows a failed job is not run
    }
    m_changed.notify_all();
  }
}

}  // namespace fascia::app
