// Starts the disk writes of a file's dirty pages on a thread of its own (Linux's sync_file_range
// with SYNC_FILE_RANGE_WRITE; elsewhere nothing), so that the rows a run writes reach the disk
// while the next steps run instead of waiting in the page cache for the fsync of the next
// checkpoint (io/checkpoint.hpp), which would then write them all at once. sync_file_range queues
// the writes in the caller's context (the file system's block allocation and the I/O submission):
// 3-4 ms per row of the pelvis at 56 k samples (14 MB) on an H200 host, which the writer of the
// rows would otherwise spend before it takes the next one.
//
// Advisory: durability is the checkpoint's fsync, where errors surface. The thread works on its
// own duplicate of the descriptor, so closing the file does not race it.
#pragma once

#include <condition_variable>
#include <mutex>
#include <thread>

namespace fascia {

class BackgroundWriteback {
 public:
  // fd: an open descriptor of the file, duplicated here (an invalid one: request() does nothing).
  explicit BackgroundWriteback(int fd);
  ~BackgroundWriteback();  // waits for a writeback in progress
  BackgroundWriteback(const BackgroundWriteback&) = delete;
  BackgroundWriteback& operator=(const BackgroundWriteback&) = delete;

  // Asks for the writes of every page dirty now to start; returns at once. Requests made while
  // one runs are served by one more pass.
  void request();

 private:
  void serve();

  int m_fd = -1;
  std::mutex m_mutex;
  std::condition_variable m_changed;
  bool m_pending = false, m_quit = false;
  std::thread m_thread;
};

}  // namespace fascia
