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

// Design of the force and tangent-product passes (elasticity_phases.hpp).
//  paper: the paper's two kernels with a partial-force buffer of one 6-vector per pair.
//  fused: F and the material cache stored by the force pass, several threads per sample in the
//         tangent product, pair sums reduced per frame in shared memory.
enum class Design { paper, fused };

// Sample pass of the fused design's tangent product (elasticity_phases.hpp).
//  coalesced: pairs in ELL order and the samples' state component-major (every per-pair and
//             per-sample load coalesced), frames as lever records read with vector loads, all
//             arithmetic in the storage precision.
//  lanes:     F and the material cache read per sample, frames gathered value by value, double
//             arithmetic.
//  records:   F rebuilt from the frames with dF, packed records read with vector loads.
//  staged:    the block's frames and samples staged in shared memory, pairs in ELL order.
// Measured on an H200: docs/benchmarks.md.
enum class SamplePass { records, lanes, staged, coalesced };

const char* to_string(Precision precision);
const char* to_string(Design design);
const char* to_string(SamplePass pass);

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

struct DeviceOptions {
  Precision precision = Precision::double_precision;
  Design design = Design::fused;
  bool reorder_samples = true;  // Morton order of samples on the device
  int block_samples = 128;      // fused design: samples per thread block
  // Fused design: the tangent product's sample pass. `staged` runs one thread per sample and is
  // used only with lanes <= 1.
  SamplePass sample_pass = SamplePass::coalesced;
  // Fused design, records and lanes passes: threads per sample in the tangent product (rounded up
  // to a power of two, at most 32); 0 = measured default (device_elasticity.cu, default_lanes).
  int lanes = 0;
  int lane_threads = 128;       // fused design: at most this many threads per tangent block (32..512)
  // Records pass: pairs per lane whose levers stay in registers (1 or 2; further pairs are read
  // again for the outputs). The coalesced pass sizes its register-held pairs itself.
  int record_keep = 2;
  // Coalesced pass: ELL entries per lane held in registers between its two halves (2, 4 or 8;
  // further ones are read again); 0 = 2 in double or where a lane has at most 2 pairs, else 4.
  // Measured on an H100 (docs/benchmarks.md, seventh round), launched PCG in double: 2 against 4
  // took 34,848 samples x 4 from 1.60 to 1.51 ms per step and 4.18 M x 8 from 1.89 to 1.85 ms per
  // CG iteration (with 4 the kernel spills 16 bytes); in single 4 is the faster at 8 pairs.
  int coalesced_keep = 0;
  // Coalesced pass: lanes that sum one slot of a block's pair outputs (a power of two, 1..32; 1:
  // one thread per slot). Measured on an H100 (docs/benchmarks.md, tenth round, interleaved
  // positions): 4.18 M x 8, ms per CG iteration, 1 -> 2: single 0.970 -> 0.933, double 1.791 ->
  // 1.738; at 34,848 samples (resident PCG) the two are even (0.676 and 0.898 ms per step).
  int slot_lanes = 2;
  // Coalesced pass, launched tangent product: with 128-thread blocks, the kernel compiled for the
  // most blocks per multiprocessor its registers allow without local memory
  // (elasticity_kernels.cuh, dense_blocks_per_sm); false: compiled for blocks of up to 512 threads.
  // Measured on an H100 (docs/benchmarks.md, seventh round): 4.18 M x 8 in single from 1.18 to
  // 1.02 ms per CG iteration; in double with 2 held entries both kernels have the same bounds.
  bool dense_tangent = true;
  // Coalesced pass, launched tangent product: where the samples fall into few shape classes
  // (kernels/shape_classes.hpp; mesh-based models), w and g of every pair formed from its sample's
  // class and map A_s instead of read per pair. Off by default: measured slower on an H100
  // (docs/benchmarks.md, seventh round; 4.18 M x 8 single, tangent product 0.85 -> 1.01 ms) though
  // it moves half the bytes: the pass is bound by latency, not bandwidth.
  bool shape_classes = false;
  // Coalesced pass, launched dense tangent kernel without shape classes: each block stages its
  // frames' lever records and directions in shared memory once (kSlotFrameRecord values per slot)
  // and its pairs read them there, instead of gathering 18 values per pair through the L1, which
  // bounds the 4.18 M pass (docs/benchmarks.md, seventh round). The same bits.
  bool slot_frames = false;
  // Coalesced pass, launched PCG: the direction p = z + beta p formed once per iteration by its own
  // pass after the update (k_pcg_direction, as the paper design does), so the tangent pass gathers
  // the 6 values of p per pair instead of the 12 of z and the previous p, and the frame pass reads
  // p instead of forming it. The same bits (the same rounding, next_direction).
  bool direction_pass = false;
  // Coalesced pass, launched dense tangent kernel gathering its frames (no shape classes or slot
  // frames), 2 or 4 held entries: the held entries' pairs (levers M = a g^T + w R, g, frame) stay in
  // registers from the dF half to the output half, which then gathers no lever record for them.
  // The same bits; more registers, so fewer blocks per multiprocessor (dense_blocks_per_sm).
  bool hold_pairs = false;
  // Coalesced pass, launched dense tangent kernel gathering its frames, 2 or 4 held entries: the
  // frames of the next 2 or 4 pairs of each lane are read together with the held entries and kept,
  // so that those pairs' lever records and directions are gathered without first waiting for
  // their entries (Nsight Compute: the chain ELL entry -> frame -> lever record dominates the
  // 4.18 M pass's stalls; docs/benchmarks.md, eighth round). The same bits. Measured on an H100 at
  // 4.18 M (ninth round): no faster than the default (single 1.071 against 1.021 ms per CG
  // iteration with 4 held entries; double at best 1 % under it), so off.
  bool prefetch_frames = false;
  // Coalesced pass, launched tangent product: the grouped pass (group_pass.hpp), where the model's
  // samples fall into groups with the same frames (mesh-based models: the samples of one cell) of
  // 2 samples on average at least and have at most 8 frames each. Eight threads per group, one per
  // sample; each frame's record is formed once per group, which turns a pair's dF into 27
  // multiply-adds, and the group's outputs are summed per frame across its threads, so that the
  // block's shared memory takes one output per (group, frame) instead of one per pair. Samples are
  // then in group order on the device (groups in Morton order). The persistent PCG kernels, used
  // for small models, keep the coalesced pass. Measured on an H100 (docs/benchmarks.md, eleventh
  // round), hexahedra x 8 launched, ms per CG iteration, coalesced -> grouped: 131,072 samples
  // single 0.052 -> 0.033, double 0.067 -> 0.057; 4.18 M single 0.936 -> 0.575, double 1.735 ->
  // 1.120.
  bool group_samples = true;
  // Grouped pass: w and g of every pair formed from its group's class and map A_g
  // (group_classes.hpp; mesh-based models of tetrahedra or parallelepiped hexahedra) instead of
  // read per pair: 10 values per group instead of 4 per pair. Off by default: measured slower on an
  // H100 (docs/benchmarks.md, eleventh round; 4.18 M x 8, ms per CG iteration, per pair -> classes:
  // single 0.575 -> 0.636, double 1.120 -> 1.421) though it moves a third of the bytes: the pass is
  // bound by latency, and the classes' table loads and maps add work and registers.
  bool group_classes = false;
  // Frames per chunk of the launched frame-row passes (k_frame_rows, k_update_rows; one chunk per
  // thread block at a time): 6 threads per frame, 1..85. Measured on an H200 (docs/benchmarks.md),
  // when each chunk was a block of its own and the grid reductions had one level: 42 against 16
  // took 4.18 M x 8 from 1.92 to 1.73 ms per CG iteration (single) and 34,848 samples from 27.2
  // to 25.5 us (launches); 85 was within 1.5 % of 42. Not measured again since the passes loop
  // over their chunks and the reductions have two levels (twelfth round).
  int row_frames = 42;
  // Launched frame pass of the tangent product: one thread per frame, reading its frame's
  // directions and slot partials in vector loads (k_frame_sums), instead of one thread per frame
  // row in chunks of row_frames frames (k_frame_rows). The same values row by row; p . A p adds
  // each frame's rows first. Measured on an H100 (docs/benchmarks.md, twelfth round): 4.18 M x 8
  // single, the pass 83.1 -> 70.5 us at base clocks.
  bool frame_threads = true;
  // Launched row passes: at most this many thread blocks, which loop over their work (0: as many
  // as fit on the device at once). The tests set it to make small models loop.
  int row_blocks = 0;
  // Persistent PCG (StepOptions::persistent): used while the model needs at most this many
  // thread blocks per multiprocessor (its blocks must all be resident). Measured on an H200
  // (docs/benchmarks.md): at 34,848 samples (273 blocks) 25.3 us per CG iteration persistent
  // against 28.8 us with launches.
  int persistent_blocks_per_sm = 4;
  // Persistent PCG of the coalesced pass with the loop invariants held in registers
  // (k_pcg_resident), where every block holds at most one sample block and one chunk of frame
  // rows, blocks have 128 threads, lanes is 1 and samples have at most 8 pairs (single precision);
  // else two grid barriers per iteration without them (k_pcg_two_barrier).
  bool resident = true;
  // The same in double precision where `resident_double` is set as well and samples have at most
  // 4 pairs: the kernel holds part of the invariants in shared memory (with 8 pairs it would spill
  // to local memory). Measured on an H100 (docs/benchmarks.md, seventh round): 34,848 samples in
  // double from 1.41 to 1.25 ms per step (21.8 to 18.9 us per CG iteration).
  bool resident_double = true;
  // The double resident kernel for 4 pairs per sample with each block's frames staged in shared
  // memory: their lever records [R_i, x̄_i] once, their directions p_i at the start of each
  // iteration (formed by the block's threads together), and the samples' materials, so that its
  // pairs read them there instead of gathering them from global memory one pair after another
  // (each grid barrier invalidates the L1, so those gathers went to the L2; Nsight Compute,
  // docs/benchmarks.md, eighth round). The same bits. Used where the kernel needs no local memory
  // and the larger shared memory leaves enough blocks per multiprocessor, else the kernel without
  // it. Measured on an H100 at 34,848 samples: 1.259 to 1.148 ms per step (eighth round); with the
  // ninth round's batched loads 14.0 against 15.8 us per CG iteration without it. Single precision
  // (levers in registers) staging its directions alone was no faster, so it does not.
  bool resident_frames = true;
};

class DeviceBackwardEuler;

// Per-thread resources of a compiled kernel (cudaFuncGetAttributes).
struct KernelResources {
  int registers = 0;
  long long local_bytes = 0;  // local memory: register spills and stack
};

// Grids of the launched PCG's row passes: their blocks of work (the frame pass: chunks of
// DeviceOptions::row_frames frames, or blocks of kFrameThreads frames with
// DeviceOptions::frame_threads; the update: chunks) and the thread blocks of each, which loop over
// them (DeviceOptions::row_blocks); and the blocks per chunk of the grid reductions' first level.
struct LaunchGrids {
  int frame_work = 0, update_work = 0, frame_rows_grid = 0, update_rows_grid = 0;
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
  // Precomputes F, P (and, for the paper design, the material cache and a = R l) and the per-frame
  // rotational blocks; returns the energy. Call before apply_tangent / tangent_diagonal_blocks.
  double prepare();
  // out = K d, [N][6] host memory, as Elasticity::apply_tangent.
  void apply_tangent(const double* d, double* out);
  // K_ii [N][36] row-major, as Elasticity::tangent_diagonal_blocks.
  void tangent_diagonal_blocks(double* blocks);

  // The design in use: `fused` falls back to `paper` when the model's rest offsets are not p_s - x_i.
  Design design() const;
  // Fused design: the tangent product's sample pass in use (DeviceOptions::sample_pass).
  SamplePass sample_pass() const;
  // Fused design: threads per sample of the records or lanes pass in use.
  int lanes() const;
  // Coalesced pass: whether the launched tangent product uses the dense kernel
  // (DeviceOptions::dense_tangent with 128-thread blocks).
  bool dense_tangent() const;
  // Coalesced pass: whether the launched tangent product takes w and g from the samples' shape
  // classes (DeviceOptions::shape_classes, where the model has them).
  bool shape_classes() const;
  // Why the model does not use shape classes where DeviceOptions::shape_classes asked for them
  // (empty otherwise).
  const std::string& shape_classes_refusal() const;
  // Coalesced pass: whether the launched tangent product runs the grouped pass
  // (DeviceOptions::group_samples, where the model allows it), and why not where it was asked for.
  bool group_samples() const;
  const std::string& group_samples_refusal() const;
  // Grouped pass: whether w and g come from the groups' classes (DeviceOptions::group_classes),
  // and why not where they were asked for.
  bool group_classes() const;
  const std::string& group_classes_refusal() const;
  // Coalesced pass: whether the launched tangent kernel reads the frames from shared memory
  // (DeviceOptions::slot_frames with the dense kernel and no shape classes).
  bool slot_frames() const;
  // Coalesced pass: whether the launched PCG forms the direction in its own pass
  // (DeviceOptions::direction_pass).
  bool direction_pass() const;
  // Coalesced pass: whether the launched tangent kernel holds its kept pairs' levers
  // (DeviceOptions::hold_pairs with the dense gathering kernel and 2 or 4 held entries).
  bool hold_pairs() const;
  // Coalesced pass: whether the launched tangent kernel prefetches its next pairs' frames
  // (DeviceOptions::prefetch_frames with the dense gathering kernel and 2 or 4 held entries).
  bool prefetch_frames() const;
  // Whether the configured step's persistent PCG is the double resident kernel with staged frames
  // (DeviceOptions::resident_frames; false before a step is configured).
  bool resident_frames() const;
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
  // Test support: the launched row passes' chunks and grids.
  LaunchGrids launch_grids() const;

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
  // Fused design: the whole PCG loop in one cooperative kernel with grid barriers (no launch per
  // phase; tolerance checked every iteration on the device), used where the model's sample blocks
  // fit in one resident wave of the device; launches per phase otherwise.
  bool persistent = true;
  bool preconditioner = true;           // block-Jacobi PCG (as LinearMethod::pcg); false: plain CG
  double rayleigh_mass = 0;             // alpha, 1/s
  double rayleigh_stiffness = 0;        // beta, s
  std::vector<double> external_forces;  // [N][6] constant generalised forces (N, N m) or empty
  std::vector<double> load_rotational_blocks;  // [N][9] L_i (N m), row-major, or empty
};

struct StepReport {
  bool persistent = false;          // the PCG ran as one cooperative kernel
  bool resident = false;            // ... with the loop invariants in registers (DeviceOptions::resident)
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
