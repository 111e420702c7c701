#include "core/fnv1a.hpp"

#include <catch2/catch.hpp>

#include <cstdint>
#include <cstring>

using namespace fascia;

TEST_CASE("FNV-1a over bytes gives the published 64-bit test vectors", "[core]") {
  // The reference values of the FNV authors' test suite (FNV-1a, 64 bits).
  CHECK(fnv1a_bytes(kFnv1aOffset, "", 0) == 0xcbf29ce484222325ull);
  CHECK(fnv1a_bytes(kFnv1aOffset, "a", 1) == 0xaf63dc4c8601ec8cull);
  CHECK(fnv1a_bytes(kFnv1aOffset, "foobar", 6) == 0x85944171f73967e8ull);
  // Carried over pieces, the hash of the whole.
  CHECK(fnv1a_bytes(fnv1a_bytes(kFnv1aOffset, "foo", 3), "bar", 3) == 0x85944171f73967e8ull);
}

TEST_CASE("a word-wise FNV-1a step takes the word's bits at once", "[core]") {
  // A word below 256 is the byte step; a wider one differs from its bytes taken in turn.
  CHECK(fnv1a_step(kFnv1aOffset, 'a') == 0xaf63dc4c8601ec8cull);
  const std::uint64_t word = 0x0102030405060708ull;
  unsigned char bytes[8];
  std::memcpy(bytes, &word, 8);
  CHECK(fnv1a_step(kFnv1aOffset, word) != fnv1a_bytes(kFnv1aOffset, bytes, 8));
  CHECK(fnv1a_step(kFnv1aOffset, word) == (kFnv1aOffset ^ word) * kFnv1aPrime);
}
