// The writeback thread of a trajectory file: it works on its own descriptor, which it closes when
// it ends, and a descriptor it cannot use makes it do nothing.
#include "io/background_writeback.hpp"

#include <catch2/catch.hpp>

#include <fcntl.h>
#include <unistd.h>

#include <filesystem>
#include <vector>

using namespace fascia;
namespace fs = std::filesystem;

namespace {

std::size_t open_descriptors() {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator("/proc/self/fd")) ++n;
  return n;
}

}  // namespace

TEST_CASE("the writeback thread keeps its own descriptor and closes it", "[io]") {
  const fs::path path = fs::temp_directory_path() / "fascia_test_writeback.bin";
  const std::size_t before = open_descriptors();
  {
    const int fd = ::open(path.c_str(), O_CREAT | O_TRUNC | O_WRONLY, 0644);
    REQUIRE(fd >= 0);
    BackgroundWriteback writeback(fd);
    const std::vector<char> block(1 << 20, 'x');
    for (int k = 0; k < 4; ++k) {
      REQUIRE(::write(fd, block.data(), block.size()) == static_cast<ssize_t>(block.size()));
      writeback.request();
    }
    // The file closed while its writeback may still run: the thread's duplicate stays valid.
    REQUIRE(::close(fd) == 0);
    CHECK(open_descriptors() == before + 1);
    writeback.request();
  }
  CHECK(open_descriptors() == before);
  CHECK(fs::file_size(path) == 4u << 20);
  fs::remove(path);
}

TEST_CASE("a writeback without a descriptor does nothing", "[io]") {
  const std::size_t before = open_descriptors();
  {
    BackgroundWriteback writeback(-1);
    writeback.request();
    CHECK(open_descriptors() == before);
  }
  CHECK(open_descriptors() == before);
}
