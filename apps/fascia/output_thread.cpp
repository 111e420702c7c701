#include "output_thread.hpp"

#include <omp.h>

#include <utility>

namespace fascia::app {

OutputThread::OutputThread(bool background, int threads) {
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

void OutputThread::wait_idle(std::unique_lock<std::mutex>& lock) {
  m_changed.wait(lock, [this] { return !m_busy; });
  if (m_error) std::rethrow_exception(std::exchange(m_error, nullptr));
}

void OutputThread::submit(std::function<void()> job) {
  std::unique_lock<std::mutex> lock(m_mutex);
  wait_idle(lock);
  if (!m_thread.joinable()) {
    lock.unlock();
    job();
    return;
  }
  m_job = std::move(job);
  m_busy = true;
  lock.unlock();
  m_changed.notify_all();
}

void OutputThread::finish() {
  std::unique_lock<std::mutex> lock(m_mutex);
  wait_idle(lock);
}

void OutputThread::serve(int threads) {
  // A new thread starts from the process's initial OpenMP settings, not the caller's.
  omp_set_num_threads(threads);
  std::unique_lock<std::mutex> lock(m_mutex);
  for (;;) {
    m_changed.wait(lock, [this] { return m_busy || m_quit; });
    if (!m_busy) return;  // quit, nothing in flight
    std::function<void()> job = std::move(m_job);
    lock.unlock();
    std::exception_ptr error;
    try {
      job();
    } catch (...) {
      error = std::current_exception();
    }
    lock.lock();
    m_error = error;
    m_busy = false;
    m_changed.notify_all();
  }
}

}  // namespace fascia::app
