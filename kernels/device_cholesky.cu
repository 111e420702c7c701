#include "device_cholesky.hpp"

#include "device_buffers.cuh"
#include "core/fnv1a.hpp"
#include "integrate/tangent_probing.hpp"
#include "solve/diagonal_shifts.hpp"

#include <cublas_v2.h>
#include <cusolverDn.h>
#include <dlfcn.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#define FASCIA_STRINGIFY_(x) #x
#define FASCIA_STRINGIFY(x) FASCIA_STRINGIFY_(x)

namespace fascia::gpu {
namespace {

constexpr long long kMaxDenseDofs = 32768;  // two matrices of 8 GiB; a factorisation of ~4e13 flops
constexpr int kThreads = 256;

// cuSOLVER and cuBLAS are loaded when a factorisation is first asked for, not at program start:
// the libraries and what they load (cuSPARSE, nvJitLink) are 1 GB, which every run would otherwise
// map.
struct Cusolver {
  decltype(&cusolverDnCreate) create = nullptr;
  decltype(&cusolverDnDestroy) destroy = nullptr;
  decltype(&cusolverDnSetStream) set_stream = nullptr;
  decltype(&cusolverDnDpotrf_bufferSize) potrf_buffer_size = nullptr;
  decltype(&cusolverDnDpotrf) potrf = nullptr;
  decltype(&cublasCreate_v2) blas_create = nullptr;
  decltype(&cublasDestroy_v2) blas_destroy = nullptr;
  decltype(&cublasSetStream_v2) blas_set_stream = nullptr;
  decltype(&cublasDtrsm_v2) trsm = nullptr;
  decltype(&cublasDsyrk_v2) syrk = nullptr;
  decltype(&cublasDsyrkx) syrkx = nullptr;
  decltype(&cublasDgemm_v2) gemm = nullptr;
  std::string error;  // why they could not be loaded; empty when loaded
};

const Cusolver& cusolver() {
  static const Cusolver api = [] {
    Cusolver c;
    void* lib = dlopen("libcusolver.so." FASCIA_STRINGIFY(CUSOLVER_VER_MAJOR), RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
      const char* e = dlerror();
      c.error = std::string("the CUDA toolkit's cuSOLVER could not be loaded (") + (e ? e : "dlopen failed") + ")";
      return c;
    }
    auto load = [&](auto& f, const char* name) {
      f = reinterpret_cast<std::remove_reference_t<decltype(f)>>(dlsym(lib, name));
      if (!f && c.error.empty()) c.error = std::string("cuSOLVER lacks ") + name;
    };
    load(c.create, "cusolverDnCreate");
    load(c.destroy, "cusolverDnDestroy");
    load(c.set_stream, "cusolverDnSetStream");
    load(c.potrf_buffer_size, "cusolverDnDpotrf_bufferSize");
    load(c.potrf, "cusolverDnDpotrf");
    void* blas = dlopen("libcublas.so." FASCIA_STRINGIFY(CUBLAS_VER_MAJOR), RTLD_NOW | RTLD_LOCAL);
    if (!blas) {
      const char* e = dlerror();
      c.error = std::string("the CUDA toolkit's cuBLAS could not be loaded (") + (e ? e : "dlopen failed") + ")";
      return c;
    }
    lib = blas;
    load(c.blas_create, "cublasCreate_v2");
    load(c.blas_destroy, "cublasDestroy_v2");
    load(c.blas_set_stream, "cublasSetStream_v2");
    load(c.trsm, "cublasDtrsm_v2");
    load(c.syrk, "cublasDsyrk_v2");
    load(c.syrkx, "cublasDsyrkx");
    load(c.gemm, "cublasDgemm_v2");
    return c;
  }();
  return api;
}

void cusolver_check(cusolverStatus_t s, const char* what) {
  if (s != CUSOLVER_STATUS_SUCCESS)
    throw std::runtime_error(std::string("cuSOLVER error ") + std::to_string(static_cast<int>(s)) + " in " + what);
}
#define FASCIA_CUSOLVER(call) cusolver_check((call), #call)

void cublas_check(cublasStatus_t s, const char* what) {
  if (s != CUBLAS_STATUS_SUCCESS)
    throw std::runtime_error(std::string("cuBLAS error ") + std::to_string(static_cast<int>(s)) + " in " + what);
}
#define FASCIA_CUBLAS(call) cublas_check((call), #call)

unsigned blocks_for(long long n) { return static_cast<unsigned>((n + kThreads - 1) / kThreads); }

__global__ void k_probe(const std::uint8_t* fixed, int body, int k, double* e, long long n) {
  const long long i = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x;
  if (i < n) e[i] = probe_entry(fixed, body, k, static_cast<int>(i));
}

// The entries of the product of body frame `body`, component k, less the assembled blocks' share
// (probe_value), into column-major A (n rows; entry (r, c) at A[c n + r]): the body's column and,
// transposed, its row.
__global__ void k_scatter(const std::uint8_t* fixed, const int* body_blocks_c, const double* blocks, int body, int k,
                          const double* out, double* A, long long n) {
  const long long i = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x;
  if (i >= n) return;
  const long long col = probe_column(fixed, body, k, static_cast<int>(i));
  if (col < 0) return;
  const double v = probe_value(out[i], fixed, body_blocks_c, blocks, body, k, static_cast<int>(i));
  A[col * n + i] = v;
  A[i * n + col] = v;
}

// A += the assembled blocks [B][36] (rows of block p: frame block_rows[p]) between free DOFs: each
// block (a, b) with b < a at its place and transposed at (b, a), the diagonal blocks once (the
// blocks with b > a hold no values: tangent_probing.hpp). One thread per entry.
__global__ void k_add_blocks(const int* block_rows, const int* block_frames, const double* blocks,
                             const std::uint8_t* fixed, long long entries, double* A, long long n) {
  const long long t = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x;
  if (t >= entries) return;
  const long long p = t / 36;
  const int a = block_rows[p], b = block_frames[p];
  if (b > a) return;
  const int e = static_cast<int>(t - 36 * p);
  const long long i = 6LL * a + e / 6, j = 6LL * b + e % 6;
  if (fixed[i] || fixed[j]) return;
  A[j * n + i] += blocks[t];
  if (a != b) A[i * n + j] += blocks[t];
}

// Keeps the diagonal, sets identity rows and columns at fixed DOFs (their entries are zero).
__global__ void k_finish(const std::uint8_t* fixed, double* A, double* diag, long long n) {
  const long long i = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x;
  if (i >= n) return;
  if (fixed[i]) A[i * n + i] = 1.0;
  diag[i] = A[i * n + i];
}

// Restores the lower triangle from the strict upper one and shifts the diagonal:
// A_ii = diag_i + tau max(|diag_i|, floor) on free DOFs. One block of kRestoreTile x
// kRestoreRows threads per tile of kRestoreTile^2 entries (tile row I >= tile column J of the
// lower triangle), transposed through shared memory so that the upper triangle's columns are read
// and the lower triangle's columns written in whole rows of the tile (coalesced both ways).
constexpr int kRestoreTile = 32, kRestoreRows = 8;

__global__ void k_restore_shifted(const std::uint8_t* fixed, const double* diag, double tau, double floor, double* A,
                                  long long n) {
  __shared__ double tile[kRestoreTile][kRestoreTile + 1];  // +1: no bank conflicts on the transpose
  const long long I = blockIdx.x, J = blockIdx.y;          // the tile's rows i in I, columns j in J
  if (I < J) return;
  const long long i0 = I * kRestoreTile, j0 = J * kRestoreTile;
  // Upper entries (j, i), i in I, j in J: column i of A, rows j0 + threadIdx.x.
  for (int r = threadIdx.y; r < kRestoreTile; r += kRestoreRows) {
    const long long i = i0 + r, j = j0 + threadIdx.x;
    if (i < n && j < n) tile[threadIdx.x][r] = A[i * n + j];
  }
  __syncthreads();
  // Lower entries (i, j) with i > j: column j of A, rows i0 + threadIdx.x.
  for (int c = threadIdx.y; c < kRestoreTile; c += kRestoreRows) {
    const long long j = j0 + c, i = i0 + threadIdx.x;
    if (i >= n || j >= n) continue;
    if (i > j)
      A[j * n + i] = tile[c][threadIdx.x];
    else if (i == j)
      A[j * n + j] = fixed[j] ? 1.0 : diag[j] + tau * fmax(fabs(diag[j]), floor);
  }
}

// The lower triangle of A (n x n, column-major) in single precision into S (leading dimension
// ld >= n): S's rows n..ld-1 zero, its strict upper triangle not written.
__global__ void k_lower_to_single(const double* A, float* S, long long n, long long ld) {
  const long long j = blockIdx.y, i = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x;
  if (i >= ld || i < j) return;
  S[j * ld + i] = i < n ? static_cast<float>(A[j * n + i]) : 0.0f;
}

// The preconditioner's product z = S r, S symmetric stored as its lower triangle in single
// precision (column-major, leading dimension ld: n rounded up to 4, its rows n..ld-1 zero), in
// double arithmetic. Every tile (I, J), J <= I, of kTile x kTile entries is read once and used
// twice: S_IJ r_J for rows I, S_IJ^T r_I for rows J, each written as one partial sum of the
// partials [nt][nt][kTile] (block row, tile, row); k_symmetric_sums adds each row's partials in
// tile order: the same bits on every run. One pass over n^2 / 2 floats, at the device's memory
// bandwidth, plus nt^2 kTile doubles twice (n^2 / 8 bytes).
constexpr int kTile = 64;
constexpr int kTileThreads = 256;  // 16 quads of rows x 16 groups of columns

__global__ void __launch_bounds__(kTileThreads)
    k_symmetric_tiles(const float* S, long long ld, int n, int nt, const double* r, double* partials) {
  __shared__ double row_sums[16][kTile];
  __shared__ double column_sums[kTile];
  // Tile (I, J) of linear index b = I (I + 1) / 2 + J.
  const long long b = blockIdx.x;
  int I = static_cast<int>((sqrt(8.0 * static_cast<double>(b) + 1.0) - 1.0) / 2.0);
  while (static_cast<long long>(I) * (I + 1) / 2 > b) --I;
  while (static_cast<long long>(I + 1) * (I + 2) / 2 <= b) ++I;
  const int J = static_cast<int>(b - static_cast<long long>(I) * (I + 1) / 2);
  const int t = static_cast<int>(threadIdx.x), quad = t % 16, group = t / 16;
  const int row = 4 * quad;  // this thread's rows row..row + 3 and columns group + 16 k of the tile
  const long long row0 = static_cast<long long>(I) * kTile + row;
  float4 a[4];
  double xc[4], xr[4];
#pragma unroll
  for (int k = 0; k < 4; ++k) {
    const long long col = static_cast<long long>(J) * kTile + group + 16 * k;
    a[k] = col < n && row0 < ld ? *reinterpret_cast<const float4*>(S + col * ld + row0) : make_float4(0, 0, 0, 0);
    xc[k] = col < n ? r[col] : 0.0;
    xr[k] = row0 + k < n ? r[row0 + k] : 0.0;
  }
  double yr[4] = {0, 0, 0, 0}, yc[4] = {0, 0, 0, 0};
#pragma unroll
  for (int k = 0; k < 4; ++k) {
    const int col = group + 16 * k;
    const double v[4] = {a[k].x, a[k].y, a[k].z, a[k].w};
#pragma unroll
    for (int i = 0; i < 4; ++i) {
      // A diagonal tile holds the lower triangle only: S_rc for r > c serves both products, S_rr
      // the direct one.
      const bool lower = I != J || row + i > col;
      const double direct = lower || row + i == col ? v[i] : 0.0;
      yr[i] += direct * xc[k];
      yc[k] += (lower ? v[i] : 0.0) * xr[i];
    }
  }
#pragma unroll
  for (int k = 0; k < 4; ++k)
    for (int offset = 8; offset > 0; offset /= 2) yc[k] += __shfl_xor_sync(0xffffffffu, yc[k], offset);
#pragma unroll
  for (int i = 0; i < 4; ++i) row_sums[group][row + i] = yr[i];
  if (quad == 0)
#pragma unroll
    for (int k = 0; k < 4; ++k) {
      if (I == J)
        column_sums[group + 16 * k] = yc[k];
      else
        partials[(static_cast<long long>(J) * nt + I) * kTile + group + 16 * k] = yc[k];
    }
  __syncthreads();
  if (t >= kTile) return;
  double sum = 0;
  for (int g = 0; g < 16; ++g) sum += row_sums[g][t];
  if (I == J) sum += column_sums[t];
  partials[(static_cast<long long>(I) * nt + J) * kTile + t] = sum;
}

// z rows of block row I (one block each): the sum of their nt partials, in tile order by 4 parts
// then the parts in order.
__global__ void __launch_bounds__(kTileThreads) k_symmetric_sums(const double* partials, int n, int nt, double* z) {
  __shared__ double part_sums[4][kTile];
  const int I = static_cast<int>(blockIdx.x), t = static_cast<int>(threadIdx.x), row = t % kTile, part = t / kTile;
  double sum = 0;
  for (int tile = part; tile < nt; tile += 4) sum += partials[(static_cast<long long>(I) * nt + tile) * kTile + row];
  part_sums[part][row] = sum;
  __syncthreads();
  const long long i = static_cast<long long>(I) * kTile + t;
  if (t < kTile && i < n) z[i] = ((part_sums[0][t] + part_sums[1][t]) + part_sums[2][t]) + part_sums[3][t];
}

// A_ii = 1 for i < m (leading dimension ld).
__global__ void k_unit_diagonal(double* A, long long m, long long ld) {
  const long long i = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x;
  if (i < m) A[i * ld + i] = 1.0;
}

// The leading half of a block of order m > kDiagonalBlock that invert_spd splits: m / 2 rounded
// up to a multiple of 128 (cuBLAS's tiles); the trailing part has at most one row more.
int split_order(int m) { return (m / 2 + 127) / 128 * 128; }

// The full symmetric m x m block of B (leading dimension ld) from the lower triangle of the block
// of A at the same place; one thread per entry, a column per blockIdx.y.
__global__ void k_symmetric_copy(const double* A, double* B, int m, long long ld) {
  const int i = static_cast<int>(blockIdx.x * blockDim.x + threadIdx.x), j = static_cast<int>(blockIdx.y);
  if (i >= m) return;
  B[j * ld + i] = i >= j ? A[j * ld + i] : A[static_cast<long long>(i) * ld + j];
}

}  // namespace

struct DeviceCholesky::Impl {
  const VectorOps& ops;
  const std::uint8_t* fixed;
  long long n = 0;
  std::uint64_t fingerprint = kFnv1aOffset;
  std::vector<int> bodies;  // the probed frames (TangentProbing::bodies)
  DeviceBuffer<int> block_rows, block_frames, body_blocks;
  DeviceBuffer<double> A, W, diag, work, probe, product, blocks;  // W: invert_spd's scratch
  DeviceBuffer<double> partials;  // the product's partial sums (k_symmetric_tiles)
  long long ld = 0;               // the leading dimension of H^{-1} in single precision
  int tiles = 0;                  // its tiles per row and column
  DeviceBuffer<int> info;
  int shift_step = -1, first_shift_step = 0;  // as SparseCholesky's
  cusolverDnHandle_t handle = nullptr;
  cublasHandle_t blas = nullptr;
  int lwork = 0;
  bool factorised = false;

  explicit Impl(DevicePotential& potential)
      : ops(potential.ops()), fixed(potential.fixed()), n(potential.model().dof_count()) {
    const std::string why = DeviceCholesky::refusal(n, potential.model().pair_count());
    if (!why.empty()) throw std::invalid_argument(why);
    const TangentProbing t = tangent_probing(potential.model());
    potential.set_tangent_blocks(t.block_offsets, t.block_frames, t.diagonal_blocks);
    bodies = t.bodies;
    for (const std::vector<int>* list : {&t.bodies, &t.block_frames})
      for (int c : *list) fingerprint = fnv1a_step(fingerprint, static_cast<std::uint32_t>(c));
    body_blocks.upload(t.body_blocks);
    std::vector<int> rows;
    for (int a = 0; a + 1 < static_cast<int>(t.block_offsets.size()); ++a)
      rows.insert(rows.end(), static_cast<size_t>(t.block_offsets[static_cast<size_t>(a) + 1] - t.block_offsets[static_cast<size_t>(a)]), a);
    block_rows.upload(rows);
    block_frames.upload(t.block_frames);
    blocks.resize(36 * t.block_frames.size());
    A.resize(static_cast<size_t>(n) * static_cast<size_t>(n));
    W.resize(static_cast<size_t>(n) * static_cast<size_t>(n));
    diag.resize(static_cast<size_t>(n));
    probe.resize(static_cast<size_t>(n));
    product.resize(static_cast<size_t>(n));
    ld = (n + 3) / 4 * 4;
    tiles = static_cast<int>((n + kTile - 1) / kTile);
    partials.resize(static_cast<size_t>(tiles) * static_cast<size_t>(tiles) * kTile);
    info.resize(1);
    FASCIA_CUSOLVER(cusolver().create(&handle));
    FASCIA_CUSOLVER(cusolver().set_stream(handle, ops.stream()));
    FASCIA_CUBLAS(cusolver().blas_create(&blas));
    FASCIA_CUBLAS(cusolver().blas_set_stream(blas, ops.stream()));
    FASCIA_CUSOLVER(cusolver().potrf_buffer_size(handle, CUBLAS_FILL_MODE_LOWER,
                                                static_cast<int>(std::min<long long>(n, kDiagonalBlock)), A.data(),
                                                static_cast<int>(n), &lwork));
    work.resize(static_cast<size_t>(std::max(lwork, 1)));
    // cuSOLVER and cuBLAS load their kernels when they are first launched (CUDA's lazy module
    // loading), tens of milliseconds each: inverting the identity of order n here loads those of
    // this order with the model's setup rather than in its first step.
    FASCIA_CUDA(cudaMemsetAsync(A.data(), 0, sizeof(double) * static_cast<size_t>(n) * static_cast<size_t>(n), ops.stream()));
    k_unit_diagonal<<<blocks_for(n), kThreads, 0, ops.stream()>>>(A.data(), n, n);
    FASCIA_CUDA(cudaGetLastError());
    if (!invert()) throw std::runtime_error("cuSOLVER potrf failed on the identity");
    // And the product of a solve, which the PCG iterations record as a CUDA graph (stream
    // capture): whatever cuBLAS sets up at its first call is set up here, outside a capture.
    FASCIA_CUDA(cudaMemsetAsync(probe.data(), 0, sizeof(double) * static_cast<size_t>(n), ops.stream()));
    product_with_inverse(probe.data(), product.data());
  }
  ~Impl() {
    if (handle) cusolver().destroy(handle);
    if (blas) cusolver().blas_destroy(blas);
  }

  // H^{-1} in single precision: the lower triangle in W's memory (W is needed only while
  // inverting; ld n <= 2 n^2 floats), leading dimension ld.
  float* inverse() { return reinterpret_cast<float*>(W.data()); }

  // z = H^{-1} r (enqueued): k_symmetric_tiles over the nt (nt + 1) / 2 tiles, then their sums.
  void product_with_inverse(const double* r, double* z) {
    const cudaStream_t stream = ops.stream();
    const unsigned lower_tiles = static_cast<unsigned>(static_cast<long long>(tiles) * (tiles + 1) / 2);
    k_symmetric_tiles<<<lower_tiles, kTileThreads, 0, stream>>>(inverse(), ld, static_cast<int>(n), tiles, r,
                                                               partials.data());
    k_symmetric_sums<<<static_cast<unsigned>(tiles), kTileThreads, 0, stream>>>(partials.data(), static_cast<int>(n),
                                                                               tiles, z);
    FASCIA_CUDA(cudaGetLastError());
  }

  // H^{-1} for the symmetric block H of order m at Hb (leading dimension n; its lower triangle
  // read and overwritten, its strict upper triangle untouched), with Wb, the block of W at the
  // same place, as scratch; false, with the rest of the recursion not run, where a diagonal block's
  // potrf fails (each one's status is read back before going on). By Schur complements, H = [A B^T; B C] with A of order
  // split_order(m):
  //   X = B A^{-1}, S = C - X B^T, H^{-1} = [A^{-1} + X^T S^{-1} X, sym.; -S^{-1} X, S^{-1}],
  // each inverse recursively, the products by cuBLAS (gemm, and syrkx where the product is known
  // to be symmetric); X lies in W's block below A's, which the recursions' blocks do not reach.
  // m^3 flops in all, as potrf, L^{-1} and L^{-T} L^{-1}, but in matrix products. H is positive
  // definite iff every S and every A of the recursion is, that is iff every diagonal block's potrf
  // succeeds. Blocks of order <= kDiagonalBlock: H = L L^T (potrf), W = L^{-1} (trsm with the
  // identity), H^{-1} = W^T W (syrk).
  bool invert_spd(double* Hb, double* Wb, int m) {
    const int order = static_cast<int>(n);
    const double one = 1.0, minus_one = -1.0, zero = 0.0;
    const cudaStream_t stream = ops.stream();
    if (m <= kDiagonalBlock) {
      FASCIA_CUSOLVER(cusolver().potrf(handle, CUBLAS_FILL_MODE_LOWER, m, Hb, order, work.data(), lwork, info.data()));
      if (read_info() != 0) return false;
      const size_t pitch = sizeof(double) * static_cast<size_t>(order), width = sizeof(double) * static_cast<size_t>(m);
      FASCIA_CUDA(cudaMemset2DAsync(Wb, pitch, 0, width, static_cast<size_t>(m), stream));
      k_unit_diagonal<<<blocks_for(m), kThreads, 0, stream>>>(Wb, m, order);
      FASCIA_CUDA(cudaGetLastError());
      FASCIA_CUBLAS(cusolver().trsm(blas, CUBLAS_SIDE_LEFT, CUBLAS_FILL_MODE_LOWER, CUBLAS_OP_N, CUBLAS_DIAG_NON_UNIT, m,
                                    m, &one, Hb, order, Wb, order));
      FASCIA_CUBLAS(cusolver().syrk(blas, CUBLAS_FILL_MODE_LOWER, CUBLAS_OP_T, m, m, &one, Wb, order, &zero, Hb, order));
      return true;
    }
    const int m1 = split_order(m), m2 = m - m1;
    const size_t at = static_cast<size_t>(m1) * static_cast<size_t>(order) + static_cast<size_t>(m1);
    double *B = Hb + m1, *C = Hb + at, *X = Wb + m1;
    if (!invert_spd(Hb, Wb, m1)) return false;
    k_symmetric_copy<<<dim3(blocks_for(m1), static_cast<unsigned>(m1)), kThreads, 0, stream>>>(Hb, Wb, m1, order);
    FASCIA_CUDA(cudaGetLastError());
    FASCIA_CUBLAS(cusolver().gemm(blas, CUBLAS_OP_N, CUBLAS_OP_N, m2, m1, m1, &one, B, order, Wb, order, &zero, X, order));
    FASCIA_CUBLAS(cusolver().syrkx(blas, CUBLAS_FILL_MODE_LOWER, CUBLAS_OP_N, m2, m1, &minus_one, X, order, B, order, &one,
                                   C, order));
    if (!invert_spd(C, Wb + at, m2)) return false;
    k_symmetric_copy<<<dim3(blocks_for(m2), static_cast<unsigned>(m2)), kThreads, 0, stream>>>(C, Wb + at, m2, order);
    FASCIA_CUDA(cudaGetLastError());
    // B becomes -S^{-1} X, then A^{-1} += X^T S^{-1} X = -X^T B.
    FASCIA_CUBLAS(cusolver().gemm(blas, CUBLAS_OP_N, CUBLAS_OP_N, m2, m1, m2, &minus_one, Wb + at, order, X, order, &zero,
                                  B, order));
    FASCIA_CUBLAS(cusolver().syrkx(blas, CUBLAS_FILL_MODE_LOWER, CUBLAS_OP_T, m1, m2, &minus_one, X, order, B, order, &one,
                                   Hb, order));
    return true;
  }

  // A's lower triangle becomes that of H^{-1} (invert_spd) and its single-precision copy is made;
  // true when H is positive definite. The strict upper triangle keeps H's.
  bool invert() {
    if (!invert_spd(A.data(), W.data(), static_cast<int>(n))) return false;
    k_lower_to_single<<<dim3(blocks_for(ld), static_cast<unsigned>(n)), kThreads, 0, ops.stream()>>>(A.data(), inverse(),
                                                                                                     n, ld);
    FASCIA_CUDA(cudaGetLastError());
    return true;
  }
  // potrf's status word (0: positive definite), read back.
  int read_info() {
    int status = 0;
    FASCIA_CUDA(cudaMemcpyAsync(&status, info.data(), sizeof(int), cudaMemcpyDeviceToHost, ops.stream()));
    FASCIA_CUDA(cudaStreamSynchronize(ops.stream()));
    if (status < 0) throw std::runtime_error("cuSOLVER potrf: invalid argument " + std::to_string(-status));
    return status;
  }
};

std::string DeviceCholesky::refusal(long long dofs, long long pairs) {
  if (!cusolver().error.empty()) return cusolver().error;
  std::ostringstream why;
  const double bytes = dense_bytes(dofs);
  const double columns = 432.0 * static_cast<double>(pairs);
  if (dofs > kMaxDenseDofs) {
    why << "the dense device factor of " << dofs << " DOFs (" << bytes / (1 << 30) << " GiB with its inverse) exceeds the "
        << kMaxDenseDofs << " DOFs the device factorises";
    return why.str();
  }
  size_t free = 0, total = 0;
  FASCIA_CUDA(cudaMemGetInfo(&free, &total));
  if (bytes + columns > 0.5 * static_cast<double>(free)) {
    why << "the dense device factor of " << dofs << " DOFs needs " << (bytes + columns) / (1 << 30)
        << " GiB (with the material columns of " << pairs << " sample pairs), more than half the "
        << static_cast<double>(free) / (1 << 30) << " GiB free on the device";
    return why.str();
  }
  return {};
}

double DeviceCholesky::dense_bytes(long long dofs) {
  // A and W, and the product's partial sums (n^2 / 64 values)
  return 16.125 * static_cast<double>(dofs) * static_cast<double>(dofs);
}

DeviceCholesky::DeviceCholesky(DevicePotential& potential) : m_impl(std::make_unique<Impl>(potential)) {}

DeviceCholesky::~DeviceCholesky() = default;

bool DeviceCholesky::factorised() const { return m_impl->factorised; }

int DeviceCholesky::products() const { return 6 * static_cast<int>(m_impl->bodies.size()); }

std::uint64_t DeviceCholesky::fingerprint() const { return m_impl->fingerprint; }

double DeviceCholesky::cost() const { return products() + static_cast<double>(m_impl->n) / 40.0; }

LinearResult DeviceCholesky::factorise(DevicePotential& potential) {
  Impl& m = *m_impl;
  const cudaStream_t stream = m.ops.stream();
  const long long n = m.n;
  m.factorised = false;
  FASCIA_CUDA(cudaMemsetAsync(m.A.data(), 0, sizeof(double) * static_cast<size_t>(n) * static_cast<size_t>(n), stream));
  const long long entries = static_cast<long long>(m.blocks.size());
  if (entries > 0) potential.tangent_blocks(m.blocks.data());
  for (size_t c = 0; c < m.bodies.size(); ++c)
    for (int k = 0; k < 6; ++k) {
      k_probe<<<blocks_for(n), kThreads, 0, stream>>>(m.fixed, m.bodies[c], k, m.probe.data(), n);
      potential.apply(m.probe.data(), m.product.data());
      k_scatter<<<blocks_for(n), kThreads, 0, stream>>>(m.fixed, m.body_blocks.data() + c * static_cast<size_t>(n / 6),
                                                        m.blocks.data(), m.bodies[c], k, m.product.data(), m.A.data(), n);
    }
  if (entries > 0)
    k_add_blocks<<<blocks_for(entries), kThreads, 0, stream>>>(m.block_rows.data(), m.block_frames.data(), m.blocks.data(),
                                                              m.fixed, entries, m.A.data(), n);
  k_finish<<<blocks_for(n), kThreads, 0, stream>>>(m.fixed, m.A.data(), m.diag.data(), n);
  FASCIA_CUDA(cudaGetLastError());

  LinearResult r;
  r.factorised = true;
  // Shifts as SparseCholesky: tau diag|H| with |H_ii| floored at 1e-12 of their mean, searched
  // from the last factorisation's (solve/diagonal_shifts.hpp). A try after a successful one
  // restores H too: the inversion writes H^{-1} into the lower triangle only.
  double mean = -1;  // found at the first shifted try
  const int step = search_shift(m.first_shift_step, [&](int k) {
    if (k >= 0) {
      if (mean < 0) {
        std::vector<double> diag(static_cast<size_t>(n));
        std::vector<std::uint8_t> fixed(static_cast<size_t>(n));
        FASCIA_CUDA(cudaMemcpyAsync(diag.data(), m.diag.data(), sizeof(double) * diag.size(), cudaMemcpyDeviceToHost, stream));
        FASCIA_CUDA(cudaMemcpyAsync(fixed.data(), m.fixed, fixed.size(), cudaMemcpyDeviceToHost, stream));
        FASCIA_CUDA(cudaStreamSynchronize(stream));
        double sum = 0;
        int free = 0;
        for (size_t i = 0; i < diag.size(); ++i)
          if (!fixed[i]) {
            sum += std::abs(diag[i]);
            ++free;
          }
        mean = free > 0 ? sum / free : 1.0;
      }
      const unsigned tiles = static_cast<unsigned>((n + kRestoreTile - 1) / kRestoreTile);
      k_restore_shifted<<<dim3(tiles, tiles), dim3(kRestoreTile, kRestoreRows), 0, stream>>>(
          m.fixed, m.diag.data(), kShifts[k], 1e-12 * mean, m.A.data(), n);
      FASCIA_CUDA(cudaGetLastError());
    }
    return m.invert();
  });
  m.factorised = step < kShiftSteps;
  m.shift_step = m.factorised ? step : -1;
  m.first_shift_step = fascia::first_shift_step(m.shift_step);
  r.converged = m.factorised;
  if (!m.factorised) {
    r.message = "device Cholesky: tangent could not be factorised even with a diagonal shift";
  } else if (m.shift_step >= 0) {
    r.shifted = true;
    std::ostringstream msg;
    msg << "device Cholesky: tangent not positive definite, shifted by " << kShifts[m.shift_step] << " diag(H)";
    r.message = msg.str();
  }
  return r;
}

int DeviceCholesky::shift_step() const { return m_impl->shift_step; }

void DeviceCholesky::set_first_shift_step(int k) {
  require_shifted_step(k);
  m_impl->first_shift_step = k;
}

void DeviceCholesky::solve(const double* r, double* z) const { m_impl->product_with_inverse(r, z); }

}  // namespace fascia::gpu
