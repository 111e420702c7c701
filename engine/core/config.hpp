// Build configuration shared by host and device code.
#pragma once

// FASCIA_WITH_CUDA is always defined (0 or 1) by the build; test it with #if.
#ifndef FASCIA_WITH_CUDA
#define FASCIA_WITH_CUDA 0
#endif

// Functions marked FASCIA_HD compile for the host and, under nvcc, for the device too:
// the sample-level mechanics is written once and used by engine/ and kernels/.
#if defined(__CUDACC__)
#define FASCIA_HD __host__ __device__ __forceinline__
#else
#define FASCIA_HD inline
#endif
