// CUDA backend of the elastic forces, tangent products and the backward-Euler Newton-PCG step
// (paper §3). Host API: including this header needs no CUDA toolkit; the implementation lives in
// device_elasticity.cu behind a pointer. Only built with FASCIA_WITH_CUDA = 1.
//
// Semantics follow the CPU reference fascia::Elasticity (engine/mechanics/elasticity.hpp): the
// same energy, gradient dW/d(theta) [N][6] (forces are its negative), symmetric tangent product
// and 6x6 diagonal blocks. Results are deterministic: repeated runs on the same device give
// bitwise-identical outputs (no floating-point atomics; every sum in an order fixed by the model).
#pragma once

#include "model/model.hpp"
#include "model/state.hpp"

#include <memory>
#include <string>
#include <vector>

namespace fascia::gpu {

// Storage precision of device data. Per-sample and per-frame arithmetic runs in double registers
// in both; `single` stores the model tables, frame kinematics and CG vectors in float.
enum class Precision { double_precision, single_precision };

const char* to_string(Precision precision);

struct DeviceInfo {
  int device_count = 0;  // 0 when there is no device or no driver
  std::string name;
  int multiprocessors = 0;
  double memory_gib = 0;
  // Peak DRAM bandwidth in GB/s from the device attributes: 2 * memory clock * bus width
  // (double data rate), 0 where the attributes are unavailable.
  double peak_bandwidth_gbs = 0;
};

// Never throws; device_count = 0 without a usable device.
DeviceInfo device_info();

// What a user chooses; the kernels and their sizes are fixed (docs/gpu.md).
struct DeviceOptions {
  Precision precision = Precision::double_precision;
};

class DeviceBackwardEuler;

// Per-thread resources of a compiled kernel (cudaFuncGetAttributes).
struct KernelResources {
  int registers = 0;
  long long local_bytes = 0;  // local memory: register spills and stack
};

// Grids of the launched PCG's row passes: their blocks of work (the frame pass: blocks of
// kFrameThreads frames; the update: chunks of frame rows) and the thread blocks of each, which
// loop over them; and the blocks per chunk of the grid reductions' first level.
struct LaunchGrids {
  int frame_work = 0, update_work = 0, frame_grid = 0, update_grid = 0;
  int reduce_chunk = 0;
};

// The model uploaded once to the device; the state is uploaded with set_state and stays there.
class DeviceElasticity {
 public:
  explicit DeviceElasticity(const Model& model, const DeviceOptions& options = {});
  ~DeviceElasticity();
  DeviceElasticity(const DeviceElasticity&) = delete;
  DeviceElasticity& operator=(const DeviceElasticity&) = delete;

  void set_state(const State& state);
  void get_state(State& state) const;

  double energy();
  // Energy and gradient [N][6] (host memory), as Elasticity::gradient.
  double gradient(double* gradient);
  // Precomputes F, P, the samples' state of the tangent product and the per-frame rotational
  // blocks; returns the energy. Call before apply_tangent / tangent_diagonal_blocks. Without
  // `diagonal_blocks` the 6x6 blocks K_ii (one differential of P per pair and direction, most of
  // the preparation's work) are left out: tangent_diagonal_blocks and diagonal_blocks_on_device
  // are then not valid.
  double prepare(bool diagonal_blocks = true);
  // out = K d, [N][6] host memory, as Elasticity::apply_tangent.
  void apply_tangent(const double* d, double* out);
  // K_ii [N][36] row-major, as Elasticity::tangent_diagonal_blocks.
  void tangent_diagonal_blocks(double* blocks);

  // The same on device memory, for the device-resident step (device_potential.hpp): every
  // pointer is a device array of doubles, the work is enqueued in order on stream() (a
  // cudaStream_t). set_state_on_device copies positions [N][3] and orientations [N][4];
  // gradient_on_device writes [N][6] and returns the energy (one scalar read); out = K d
  // [N][6]; the diagonal blocks K_ii [N][36] are those of the last prepare().
  void* stream() const;
  void set_state_on_device(const double* positions, const double* orientations);
  double gradient_on_device(double* gradient);
  void apply_tangent_on_device(const double* d, double* out);
  const double* diagonal_blocks_on_device() const;
  // The elastic tangent's blocks between frames that share a sample, sum_s v B_a^T C[B_b]
  // (without the rotational geometric blocks), of the last prepare(), for the blocks (a, b) of the
  // pattern set by set_tangent_blocks (host CSR over rows a: block_offsets [N+1], block_frames
  // [B]; the pattern of integrate/tangent_probing.hpp), into blocks [B][36] (device memory,
  // written, row-major). A block's samples are summed in a fixed order.
  void set_tangent_blocks(const std::vector<int>& block_offsets, const std::vector<int>& block_frames);
  void tangent_blocks_on_device(double* blocks);

  // Whether the launched tangent product runs the grouped pass (mesh-based models whose samples
  // share their frames in groups: group_layout.hpp), and why not where it does not.
  bool group_samples() const;
  const std::string& group_samples_refusal() const;
  Precision precision() const;
  const DeviceOptions& options() const;

  // Benchmark support: mean ms of one tangent product (sample and frame passes) on device data,
  // after prepare(), measured with CUDA events over `repeats` products after a warm-up; and the
  // bytes one product must move between DRAM and the chip at least (every input read once, every
  // output written once; frame data counted once), for the achieved-bandwidth figure.
  double time_tangent_ms(int repeats);
  double tangent_bytes() const;
  // Benchmark support: registers per thread and local memory (spills, stack) per thread of the
  // launched tangent product's sample kernel in use, as the CUDA runtime reports them.
  KernelResources tangent_kernel_resources() const;
  // Test support: the launched row passes' chunks and grids; at most `blocks` thread blocks in
  // each, so that a small model's row passes loop over their work as a large one's do.
  LaunchGrids launch_grids() const;
  void limit_row_blocks(int blocks);

  struct Impl;

 private:
  friend class DeviceBackwardEuler;
  std::unique_ptr<Impl> m_impl;
};

// The step solves H delta = -g with (engine/integrate/step_potential.hpp at the step start)
//   H = (1 + beta/h) K + (1 + alpha h)/h^2 diag(m_i I, R_i I_0 R_i^T) + diag(0, L_i)
//   g = dW - f_ext - M v / h
// K the elastic tangent (material + geometric), I_0 = Model::frame_inertias, L_i the load
// potential's rotational blocks, fixed DOFs projected out. make_step_options (device_step.hpp)
// fills f_ext and L from fascia::ExternalLoads so that the step equals the CPU engine's.
struct StepOptions {
  double dt = 0.01;                     // s
  int max_cg_iterations = 60;
  double cg_tolerance = 0;              // relative, on sqrt(r.z / r0.z0); 0 = run max_cg_iterations
  int check_every = 10;                 // CG iterations between host reads of the convergence flag
  bool use_graphs = true;               // replay the launches of a step as CUDA graphs
  // The whole PCG loop in one cooperative kernel with grid barriers (no launch per phase; tolerance
  // checked every iteration on the device), used where the model's sample blocks fit in one
  // resident wave of the device; launches per phase otherwise (and where false).
  bool persistent = true;
  bool preconditioner = true;           // block-Jacobi PCG (as LinearMethod::pcg); false: plain CG
  double rayleigh_mass = 0;             // alpha, 1/s
  double rayleigh_stiffness = 0;        // beta, s
  std::vector<double> external_forces;  // [N][6] constant generalised forces (N, N m) or empty
  std::vector<double> load_rotational_blocks;  // [N][9] L_i (N m), row-major, or empty
};

struct StepReport {
  bool persistent = false;          // the PCG ran as one cooperative kernel
  bool resident = false;            // ... with the loop invariants held in the kernel (k_pcg_resident)
  int cg_iterations = 0;
  double cg_relative_residual = 0;  // sqrt(r.z / r0.z0) at the end
  double energy = 0;                // elastic energy at the start of the step, J
};

// One backward-Euler step solved by one Newton iteration, entirely on the device: gradient,
// preparation (rotational blocks, block-Jacobi preconditioner), PCG on (M/h^2 + K) delta = -g with
// g = dW - f_ext - M v / h, then x <- x (+) delta, v <- delta / h. The device state advances; read
// it with DeviceElasticity::get_state. Scalars of the PCG stay on the device.
class DeviceBackwardEuler {
 public:
  DeviceBackwardEuler(DeviceElasticity& elasticity, const StepOptions& options);
  ~DeviceBackwardEuler();
  DeviceBackwardEuler(const DeviceBackwardEuler&) = delete;
  DeviceBackwardEuler& operator=(const DeviceBackwardEuler&) = delete;

  StepReport step();
  // The increment delta of the last step, [N][6] host memory.
  void last_increment(double* delta) const;

  // Benchmark support (CUDA events, after a warm-up): mean ms of a full step without host
  // transfers, and mean ms of one CG iteration of the captured loop.
  double time_step_ms(int repeats);
  double time_cg_iteration_ms(int repeats);

  struct Impl;

 private:
  std::unique_ptr<Impl> m_impl;
};

}  // namespace fascia::gpu
