// FNV-1a, 64 bits (Fowler, Noll and Vo): the fingerprints by which a run tells whether a file, a
// sparsity pattern or a factorisation's pattern is the one a result was made from. Not a defence
// against tampering.
#pragma once

#include <cstddef>
#include <cstdint>

namespace fascia {

constexpr std::uint64_t kFnv1aOffset = 14695981039346656037ull;  // the hash of nothing
constexpr std::uint64_t kFnv1aPrime = 1099511628211ull;

// One step over the value v: a byte in the classic hash; a whole word (an index, 8 bytes of a
// file) in the word-wise variant, which takes a word's bits in one step.
constexpr std::uint64_t fnv1a_step(std::uint64_t h, std::uint64_t v) { return (h ^ v) * kFnv1aPrime; }

// h carried over `bytes` bytes of data, byte by byte.
inline std::uint64_t fnv1a_bytes(std::uint64_t h, const void* data, std::size_t bytes) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < bytes; ++i) h = fnv1a_step(h, p[i]);
  return h;
}

}  // namespace fascia
