// FASCIA_CLONES: compile a host function twice, for plain x86-64 (SSE2, 2 doubles per
// instruction) and for x86-64-v3 (AVX2 + FMA, 4 doubles); the loader picks the clone the CPU
// supports, so one binary runs everywhere and uses AVX2 where it exists. For loops written for
// the compiler's vectoriser (#pragma omp simd). GCC on x86-64 only; builds with FASCIA_NATIVE
// (-march=native) need no clones.
#pragma once

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(__AVX2__) && \
    !defined(FASCIA_NO_CLONES)
#define FASCIA_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define FASCIA_CLONES
#endif

// FASCIA_CLONE_INLINE: a helper of a FASCIA_CLONES function, always inlined, so that each clone
// compiles it for its own instruction set (a helper left out of line is compiled once, for plain
// x86-64).
#if defined(__GNUC__)
#define FASCIA_CLONE_INLINE __attribute__((always_inline)) inline
#else
#define FASCIA_CLONE_INLINE inline
#endif
