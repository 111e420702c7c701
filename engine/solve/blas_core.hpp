// The kernels of the BLAS behind CHOLMOD's supernodal factorisations (solve/sparse_cholesky.hpp)
// when that BLAS is OpenBLAS built for several CPUs (Debian's libopenblas0-openmp).
//
// OpenBLAS picks its kernels by CPU model when it is loaded, and on a model newer than its table
// it falls back to its generic SSE3 kernels ("Prescott"), whatever the CPU supports: Debian 12's
// OpenBLAS 0.3.21 does so on the Emerald Rapids Xeon (family 6, model 207) of an H200 host.
// There the consistent integration of the pelvis with its finest fasciae (n 9,068, 12.3 M
// nonzeros in L) factorised in 1.29 s on an H200 host's 16 cores against 1.05 s with the AVX-512
// kernels ("SkylakeX"), and in 1.63 s against 0.89 s on two. select_blas_core() selects
// the kernels the CPU supports, as OPENBLAS_CORETYPE would, before any BLAS call: through
// OpenBLAS's exported gotoblas_dynamic_quit/gotoblas_dynamic_init, looked up at run time (no
// other BLAS is affected). A user's OPENBLAS_CORETYPE is left as it is.
#pragma once

#include <string>

namespace fascia {

// The OpenBLAS core to select instead of `current`: "SkylakeX" with AVX-512 (F, BW, VL, DQ, CD),
// "Haswell" with AVX2 and FMA, when `current` is the generic fallback "Prescott"; else empty.
std::string better_blas_core(const std::string& current, bool avx512, bool avx2_fma);

// The core of the process's OpenBLAS (empty: the BLAS is not OpenBLAS).
std::string blas_core();

// Selects OpenBLAS's kernels for core `name` (a name OPENBLAS_CORETYPE accepts); false when the
// BLAS is not OpenBLAS. No BLAS call may run meanwhile.
bool set_blas_core(const std::string& name);

// Where OPENBLAS_CORETYPE is unset and better_blas_core() names a core for this CPU, selects it
// and returns its name; else returns empty. Called first in main().
std::string select_blas_core();

}  // namespace fascia
