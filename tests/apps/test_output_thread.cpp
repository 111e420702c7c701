#include "output_thread.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

using namespace fascia::app;

namespace {
constexpr int kDepth = 4;
}  // namespace

TEST_CASE("OutputThread runs jobs in order, on its own thread or inline", "[output_thread]") {
  for (const bool background : {true, false}) {
    CAPTURE(background);
    std::vector<int> order;
    std::vector<std::thread::id> ids;
    {
      OutputThread out(background, 2, kDepth);
      for (int k = 0; k < 50; ++k)
        out.submit([&order, &ids, k] {
          order.push_back(k);
          ids.push_back(std::this_thread::get_id());
        });
      out.finish();
      REQUIRE(order.size() == 50);
      for (int k = 0; k < 50; ++k) CHECK(order[static_cast<std::size_t>(k)] == k);
      for (const std::thread::id id : ids) CHECK((id == std::this_thread::get_id()) == !background);
    }
  }
}

TEST_CASE("OutputThread runs one job at a time", "[output_thread]") {
  std::atomic<int> running{0}, most{0};
  OutputThread out(true, 1, kDepth);
  for (int k = 0; k < 20; ++k) {
    out.submit([&] {
      most = std::max(most.load(), ++running);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      --running;
    });
  }
  out.finish();
  CHECK(most.load() == 1);
}

TEST_CASE("OutputThread's submit waits while `depth` jobs are unfinished", "[output_thread]") {
  for (const int depth : {1, kDepth}) {
    CAPTURE(depth);
    std::mutex gate;
    std::unique_lock<std::mutex> closed(gate);
    std::atomic<int> ran{0};
    OutputThread out(true, 1, depth);
    const auto job = [&] {
      const std::lock_guard<std::mutex> pass(gate);
      ++ran;
    };
    // The first job holds the thread at the gate; the queue takes the rest without waiting.
    for (int k = 0; k < depth; ++k) out.submit(job);
    std::atomic<bool> queued{false};
    std::thread extra([&] {
      out.submit(job);
      queued = true;
    });
    // However long it is given, the extra submit cannot return before a job finishes.
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    CHECK_FALSE(queued.load());
    CHECK(ran.load() == 0);
    closed.unlock();
    extra.join();
    CHECK(queued.load());
    out.finish();
    CHECK(ran.load() == depth + 1);
  }
}

TEST_CASE("OutputThread rethrows a job's exception on the caller's thread and runs nothing after it",
          "[output_thread]") {
  for (const bool background : {true, false}) {
    CAPTURE(background);
    OutputThread out(background, 1, kDepth);
    bool later = false;
    const auto failing = [] { throw std::runtime_error("disk full"); };
    if (background) {
      REQUIRE_NOTHROW(out.submit(failing));
      // The exception reaches the next call after the failure: this submit if the job has failed
      // by then (its job is dropped), else finish() (the job queued behind the failure is dropped).
      int thrown = 0;
      for (const bool finishing : {false, true}) {
        try {
          if (finishing)
            out.finish();
          else
            out.submit([&later] { later = true; });
        } catch (const std::runtime_error& e) {
          CHECK(std::string(e.what()) == "disk full");
          ++thrown;
        }
      }
      CHECK(thrown == 1);
      CHECK_FALSE(later);
    } else {
      REQUIRE_THROWS_WITH(out.submit(failing), "disk full");
    }
    // Reported once: the thread goes on with later jobs.
    out.submit([&later] { later = true; });
    REQUIRE_NOTHROW(out.finish());
    CHECK(later);
  }
}

TEST_CASE("OutputThread drops the jobs queued after a failed one", "[output_thread]") {
  std::mutex gate;
  std::unique_lock<std::mutex> closed(gate);
  OutputThread out(true, 1, kDepth);
  bool queued_ran = false;
  out.submit([&gate] {
    const std::lock_guard<std::mutex> pass(gate);
    throw std::runtime_error("disk full");
  });
  out.submit([&queued_ran] { queued_ran = true; });  // queued behind the failing job
  closed.unlock();
  REQUIRE_THROWS_WITH(out.finish(), "disk full");
  CHECK_FALSE(queued_ran);
}

TEST_CASE("OutputThread's destructor runs the jobs still queued", "[output_thread]") {
  std::atomic<int> done{0};
  {
    OutputThread out(true, 1, kDepth);
    for (int k = 0; k < kDepth; ++k)
      out.submit([&done] {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        ++done;
      });
  }
  CHECK(done.load() == kDepth);
}
