#include "io/background_writeback.hpp"

#include <fcntl.h>
#include <unistd.h>

namespace fascia {

BackgroundWriteback::BackgroundWriteback(int fd) {
#if defined(__linux__)
  if (fd >= 0) m_fd = ::fcntl(fd, F_DUPFD_CLOEXEC, 0);
  if (m_fd >= 0) m_thread = std::thread([this] { serve(); });
#else
  (void)fd;
#endif
}

BackgroundWriteback::~BackgroundWriteback() {
  {
    std::lock_guard<std::mutex> lock(m_mutex);
    m_quit = true;
  }
  m_changed.notify_one();
  if (m_thread.joinable()) m_thread.join();
  if (m_fd >= 0) ::close(m_fd);
}

void BackgroundWriteback::request() {
  if (m_fd < 0) return;
  {
    std::lock_guard<std::mutex> lock(m_mutex);
    m_pending = true;
  }
  m_changed.notify_one();
}

void BackgroundWriteback::serve() {
  std::unique_lock<std::mutex> lock(m_mutex);
  for (;;) {
    m_changed.wait(lock, [this] { return m_pending || m_quit; });
    if (m_quit) return;
    m_pending = false;
    lock.unlock();
#if defined(__linux__)
    ::sync_file_range(m_fd, 0, 0, SYNC_FILE_RANGE_WRITE);  // advisory: errors surface at fsync
#endif
    lock.lock();
  }
}

}  // namespace fascia
