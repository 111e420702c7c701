// FASCIA_CLONES: compile a host function three times, for plain x86-64 (SSE2, 2 doubles per
// instruction), for x86-64-v3 (AVX2 + FMA, 4 doubles) and for x86-64-v4 (AVX-512, 8 doubles and
// 32 vector registers); the loader picks the newest clone the CPU supports, so one binary runs
// everywhere and uses AVX-512 where it exists (on a 2-core Intel Xeon VM the v4 clones took the
// liver's step from 18.8-19.3 ms to 16.2-17.4 and tool_pull's from 11.8-12.5 to 11.2-11.5). For
// loops written for the compiler's vectoriser (#pragma omp simd). GCC on x86-64 only; builds with
// FASCIA_NATIVE (-march=native) need no clones.
#pragma once

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(__AVX2__) && \
    !defined(FASCIA_NO_CLONES)
#define FASCIA_CLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
// Without the x86-64-v4 clone, for a function whose AVX-512 clone measured slower than its AVX2 one.
#define FASCIA_CLONES_AVX2 __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define FASCIA_CLONES
#define FASCIA_CLONES_AVX2
#endif

// FASCIA_CLONE_INLINE: a helper of a FASCIA_CLONES function, always inlined, so that each clone
// compiles it for its own instruction set (a helper left out of line is compiled once, for plain
// x86-64).
#if defined(__GNUC__)
#define FASCIA_CLONE_INLINE __attribute__((always_inline)) inline
#else
#define FASCIA_CLONE_INLINE inline
#endif
