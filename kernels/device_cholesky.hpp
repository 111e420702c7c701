// A Cholesky factorisation of the step tangent H on the device: the CUDA backend's counterpart of
// the CPU's CHOLMOD factor (solve/sparse_cholesky.hpp), for the pcg preconditioner of that name
// (solve/factorised_solve.hpp).
//
// H is recovered into a dense n x n matrix from its blocks between unknowns, assembled on the
// device from the samples, the shell triangles and the frame terms, and six products per rigid
// body for the bodies' rows and columns (integrate/tangent_probing.hpp; none without bodies),
// inverted by Schur complements, recursively by halves (the products by cuBLAS; diagonal blocks of
// at most kDiagonalBlock rows by cuSOLVER's potrf, H = L L^T, and cuBLAS's L^{-T} L^{-1}); the
// preconditioner is then a symmetric product with the lower triangle of H^{-1} rounded to single
// precision, in double arithmetic, one pass over its tiles
// (n^2/2 floats) at the device's memory bandwidth (where potrs's two triangular solves, sequential
// by blocks, took 1.7 ms at 11,460 DOFs on an H100, and a product with both triangles in double
// 0.37 ms). The rounding (relative 6e-8 per entry) perturbs the preconditioner, not the system PCG
// solves: its residuals and tolerances stay in double. The inverse costs n^3 flops, three times a
// factorisation's (38.5 ms at 10,962 DOFs on an H200), which the tens to hundreds of CG iterations
// each factorisation serves repay. Dense, because the scenes' reduced tangents are
// small (2,148 DOFs for the pelvis, 10,962 with its finest fasciae: 1 GB, about n^3/3 = 4e11
// flops per factorisation) while their sparse factors have deep elimination trees that
// triangular solves on a GPU walk level by level. A model whose dense factor would not fit is refused (refusal()):
// the device then preconditions by block Jacobi.
//
// Not positive definite: shifted like the CPU's, H + tau diag|H| for tau = 1e-6, 1e-5, ... 1e3,
// tried after an unshifted try from a decade below the last factorisation's shift
// (solve/diagonal_shifts.hpp; the strict upper triangle, which the inversion leaves untouched,
// restores the lower one between tries).
// cuSOLVER's and cuBLAS's kernels for the model's order are loaded when the object is made (an
// inversion of the identity and a product), not in the first step.
// Fixed DOFs are identity rows and columns. All work is enqueued on the stream of `ops`; a
// factorisation reads back one status word per diagonal block and try.
#pragma once

#include "device_potential.hpp"
#include "device_vector.hpp"
#include "model/model.hpp"
#include "solve/linear_result.hpp"
#include "solve/linear_solver.hpp"

#include <cstdint>
#include <memory>
#include <string>

namespace fascia::gpu {

class DeviceCholesky {
 public:
  // The largest diagonal block that the inversion factorises (potrf, trsm with the identity,
  // syrk) rather than splits: wide enough for cuBLAS's BLAS-3 kernels to run near their peak, and
  // the shipped scenes' tangents of up to 1,080 DOFs (the beams, which factorise at every Newton
  // iteration) are one block, the pelvis's and coupling's two. An H200 inverts H of order
  // 10,962 in 38.5-38.8 ms with blocks of 768-2048 (39.9 with 512, 41.2 with 3072; 45.1 by potrf of
  // the whole, L^{-1} and L^{-T} L^{-1}), of order 4,950 in 7.9 ms.
  static constexpr int kDiagonalBlock = 2048;
  // The largest model whose pcg the dense factor preconditions: above it the factor's n^3
  // renewals and n^2 products cost more than block Jacobi's extra iterations. The pelvis with
  // 56,179 samples and finer frames, `bench scenes --backend cuda --steps 30` on an H200, ms per
  // step (CG per step), block Jacobi against the factor: 16,194 DOFs 57.9 (390) against 26.8 (34),
  // 19,218 61.0 (411) against 37.8 (39), 23,046 63.8 (422) against 56.8 (42), 27,216 66.2 (429)
  // against 206.1 (51).
  static constexpr long long kPreconditionerDofs = 24000;
  // The largest dense factor the device keeps: n <= 32,768 DOFs (8 GiB, and as much for the
  // inversion's scratch), all within half the free device memory with the
  // pairs' material columns the elastic blocks are formed from (432 bytes per sample pair:
  // DeviceElasticity::set_tangent_blocks); cuSOLVER and cuBLAS (libcusolver, libcublas) must load.
  // Empty when a model of `dofs` DOFs and `pairs` sample pairs can be factorised now, else the
  // reason.
  static std::string refusal(long long dofs, long long pairs);
  // The dense matrices' bytes for `dofs` DOFs: H (then H^{-1}), L^{-1} and the inversion's scratch.
  static double dense_bytes(long long dofs);

  // The factor of potential's Hessian (the potential must outlive this object); sets its tangent
  // block pattern (DevicePotential::set_tangent_blocks).
  explicit DeviceCholesky(DevicePotential& potential);
  ~DeviceCholesky();
  DeviceCholesky(const DeviceCholesky&) = delete;
  DeviceCholesky& operator=(const DeviceCholesky&) = delete;

  // Recovers the Hessian H that potential.prepare_hessian prepared from its assembled blocks
  // (DevicePotential::tangent_blocks) and its products (DevicePotential::apply), and factorises
  // it. .factorised = true; .shifted and .message when shifted; .message alone when every shift
  // failed.
  LinearResult factorise(DevicePotential& potential);
  bool factorised() const;
  // The last factorisation's shift step (-1: unshifted or none), and the first shifted step the
  // next one tries (a resumed run's: as SparseCholesky's).
  int shift_step() const;
  void set_first_shift_step(int k);
  // z = H^{-1} r (device arrays of 6N; z's fixed DOFs equal r's). Enqueued only: no read back.
  void solve(const double* r, double* z) const;
  // Probe products per factorisation (6 per rigid body).
  int products() const;
  // A factorisation's cost in CG iterations, for the renewal rule of solve/kept_factorisation.hpp:
  // products() tangent products and the factorisation with its inverse, about n/40 products (an
  // H200 inverts 10,962 DOFs in about 40 ms, against a product of 150 us); a CG iteration costs
  // one product and one product with H^{-1}. bench scenes on an H200 (pelvis at three
  // resolutions) measures the same time with n/80, and more with n/25 or n/60.
  double cost() const;
  // A fingerprint of the probed bodies and the block pattern (FNV-1a): equal for one model and
  // build.
  std::uint64_t fingerprint() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> m_impl;
};

}  // namespace fascia::gpu
