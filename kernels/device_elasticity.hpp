// CUDA backend of the elastic forces and tangent products (paper §3); the step that uses them is
// kernels/device_potential.hpp with the one Newton and PCG (kernels/cuda_step.hpp). Host API:
// including this header needs no CUDA toolkit; the implementation lives in device_elasticity.cu
// behind a pointer. Only built with FASCIA_WITH_CUDA = 1.
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

// Storage precision of the tangent's device data. Per-sample and per-frame arithmetic runs in
// double registers in both; `single` stores the model tables, frame kinematics and the products'
// partial sums in float (the solver's vectors stay double: kernels/device_vector.hpp). The
// energies and gradients are double in both (DeviceElasticity says why).
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

// Creates the device's context (the runtime's primary context of the current device) now: about
// 0.1 s that the first call needing it would otherwise wait for. Never throws; errors are left to
// that call.
void create_context();

// What a user chooses; the kernels and their sizes are fixed (docs/gpu.md).
struct DeviceOptions {
  Precision precision = Precision::double_precision;
};

// Per-thread resources of a compiled kernel (cudaFuncGetAttributes).
struct KernelResources {
  int registers = 0;
  long long local_bytes = 0;  // local memory: register spills and stack
};

// Grids of the launched frame pass (k_frame_sums): its blocks of work (blocks of kFrameThreads
// frames) and the thread blocks that loop over them; and the blocks per chunk of the grid
// reductions' first level.
struct LaunchGrids {
  int frame_work = 0, frame_grid = 0;
  int reduce_chunk = 0;
};

// The model uploaded once to the device; the state is uploaded with set_state and stays there.
// In single precision the energies and gradients (Newton's residual, the line search) come from
// a second copy of the tables in double storage on the same stream, which every state set here
// reaches (the tangent's copy takes the state from it at prepare()): float tables and kinematics
// leave the gradient an error of about 1e-7 of each sample's force, and the residual of a scene
// whose internal forces are large against the net force would stall at 1e-5 to 1e-4 of the force
// scale, above Newton's tolerance. The tangent (prepare, the products and blocks) stays in the
// storage chosen.
class DeviceElasticity {
 public:
  // stream: a cudaStream_t to enqueue on, which must outlive this object (null: its own).
  explicit DeviceElasticity(const Model& model, const DeviceOptions& options = {}, void* stream = nullptr);
  ~DeviceElasticity();
  DeviceElasticity(const DeviceElasticity&) = delete;
  DeviceElasticity& operator=(const DeviceElasticity&) = delete;

  void set_state(const State& state);
  void get_state(State& state) const;

  double energy();
  // Energy and gradient [N][6] (host memory), as Elasticity::gradient.
  double gradient(double* gradient);
  // Precomputes F, P, the samples' state of the tangent product and the per-frame rotational
  // blocks; returns the energy (in the tangent's storage). Call before apply_tangent / tangent_diagonal_blocks. Without
  // `diagonal_blocks` the 6x6 blocks K_ii (one differential of P per pair and direction, most of
  // the preparation's work) are left out: tangent_diagonal_blocks and diagonal_blocks_on_device
  // are then not valid.
  double prepare(bool diagonal_blocks = true);
  // The same with nothing read back (the device-resident step's).
  void prepare_on_device(bool diagonal_blocks = true);
  // out = K d, [N][6] host memory, as Elasticity::apply_tangent.
  void apply_tangent(const double* d, double* out);
  // K_ii [N][36] row-major, as Elasticity::tangent_diagonal_blocks.
  void tangent_diagonal_blocks(double* blocks);

  // The same on device memory, for the device-resident step (device_potential.hpp): every
  // pointer is a device array of doubles, the work is enqueued in order on stream() (a
  // cudaStream_t). set_state_on_device copies positions [N][3] and orientations [N][4];
  // gradient_on_device writes [N][6] (gradient null: none) and the energy, one double at
  // energy_on_device() until the next pass, with no read back; out = K d
  // [N][6], plus D d with frame_diagonal [N][10] (t_i, then Q_i row-major; may be null), as
  // Elasticity::apply_tangent; the diagonal blocks K_ii [N][36] are those of the last prepare().
  void* stream() const;
  void set_state_on_device(const double* positions, const double* orientations);
  void gradient_on_device(double* gradient);
  const double* energy_on_device() const;
  void apply_tangent_on_device(const double* d, double* out, const double* frame_diagonal = nullptr);
  const double* diagonal_blocks_on_device() const;
  // The elastic tangent's blocks between frames that share a sample, sum_s v B_a^T C[B_b], and on
  // the diagonal blocks (a, a) the rotational geometric blocks, of the last prepare(), for the
  // blocks (a, b) of the pattern set by set_tangent_blocks (host CSR over rows a: block_offsets
  // [N+1], block_frames [B]; diagonal_blocks [N] each frame's block (a, a), -1: none; the pattern
  // of integrate/tangent_probing.hpp), into blocks [B][36] (device memory, written, row-major). A
  // block's samples are summed in a fixed order. Only the blocks with b <= a are formed (the
  // tangent is symmetric: block (a, b) for b > a is the transpose of (b, a)); the others are
  // written as zero. set_tangent_blocks allocates the pairs' material columns, 54 doubles per pair
  // (432 bytes; 0.73 GB at 1.7 M pairs), which tangent_blocks_on_device forms first.
  void set_tangent_blocks(const std::vector<int>& block_offsets, const std::vector<int>& block_frames,
                          const std::vector<int>& diagonal_blocks);
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
  // Test support: the launched frame pass's grid; at most `blocks` thread blocks, so that a small
  // model's frame pass loops over its work as a large one's does.
  LaunchGrids launch_grids() const;
  void limit_row_blocks(int blocks);

  struct Impl;

 private:
  Impl& forces() const;  // the energies' and gradients' (and the state's): m_forces in single, else m_impl
  std::unique_ptr<Impl> m_impl;    // the tangent's, in the storage chosen
  std::unique_ptr<Impl> m_forces;  // single precision: double storage on m_impl's stream
};

}  // namespace fascia::gpu
