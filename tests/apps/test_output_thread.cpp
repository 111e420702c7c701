#include "output_thread.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

using namespace fascia::app;

TEST_CASE("OutputThread runs jobs in order, on its own thread or inline", "[output_thread]") {
  for (const bool background : {true, false}) {
    CAPTURE(background);
    std::vector<int> order;
    std::vector<std::thread::id> ids;
    {
      OutputThread out(background, 2);
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

TEST_CASE("OutputThread has at most one job in flight", "[output_thread]") {
  std::atomic<int> running{0}, most{0};
  OutputThread out(true, 1);
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

TEST_CASE("OutputThread rethrows a job's exception on the caller's thread and runs nothing after it",
          "[output_thread]") {
  for (const bool background : {true, false}) {
    CAPTURE(background);
    OutputThread out(background, 1);
    bool later = false;
    const auto failing = [] { throw std::runtime_error("disk full"); };
    if (background) {
      REQUIRE_NOTHROW(out.submit(failing));
      // The exception reaches the next call, and the job given to it does not run.
      REQUIRE_THROWS_WITH(out.submit([&later] { later = true; }), "disk full");
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

TEST_CASE("OutputThread's destructor waits for the job in flight", "[output_thread]") {
  std::atomic<bool> done{false};
  {
    OutputThread out(true, 1);
    out.submit([&done] {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      done = true;
    });
  }
  CHECK(done.load());
}
