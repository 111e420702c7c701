#include "device_buffers.cuh"
#include "device_elasticity.hpp"
#include "elasticity_kernels.cuh"
#include "group_classes.hpp"
#include "group_kernels.cuh"
#include "group_layout.hpp"
#include "sample_layout.hpp"
#include "shape_classes.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numeric>
#include <optional>

namespace fascia::gpu {

const char* to_string(Precision precision) {
  return precision == Precision::double_precision ? "double" : "single";
}
const char* to_string(Design design) { return design == Design::paper ? "paper" : "fused"; }
const char* to_string(SamplePass pass) {
  switch (pass) {
    case SamplePass::records:
      return "records";
    case SamplePass::lanes:
      return "lanes";
    case SamplePass::staged:
      return "staged";
    case SamplePass::coalesced:
      return "coalesced";
  }
  return "?";
}

DeviceInfo device_info() {
  DeviceInfo info;
  int count = 0;
  if (cudaGetDeviceCount(&count) != cudaSuccess || count <= 0) {
    cudaGetLastError();  // clear the sticky "no device" error
    return info;
  }
  info.device_count = count;
  int dev = 0;
  cudaGetDevice(&dev);
  cudaDeviceProp prop{};
  if (cudaGetDeviceProperties(&prop, dev) == cudaSuccess) {
    info.name = prop.name;
    info.multiprocessors = prop.multiProcessorCount;
    info.memory_gib = static_cast<double>(prop.totalGlobalMem) / (1024.0 * 1024.0 * 1024.0);
  }
  int clock_khz = 0, bus_bits = 0;
  if (cudaDeviceGetAttribute(&clock_khz, cudaDevAttrMemoryClockRate, dev) == cudaSuccess &&
      cudaDeviceGetAttribute(&bus_bits, cudaDevAttrGlobalMemoryBusWidth, dev) == cudaSuccess)
    info.peak_bandwidth_gbs = 2.0 * clock_khz * 1e3 * (bus_bits / 8.0) / 1e9;
  cudaGetLastError();
  return info;
}

namespace {

constexpr int kThreads = 128;      // frame and sample kernels
constexpr int kPaperGather = 96;   // paper §3.3: 6 threads per frame, 96 per block
constexpr int kMaxBlockPairs = 1024;

int grid_for(long long count, int threads) { return static_cast<int>(std::max<long long>(1, (count + threads - 1) / threads)); }

}  // namespace

// The implementation behind both public classes: abstract over the storage precision.
struct DeviceElasticity::Impl {
  virtual ~Impl() = default;
  virtual void set_state(const State& state) = 0;
  virtual void get_state(State& state) const = 0;
  virtual double energy() = 0;
  virtual double gradient(double* g) = 0;
  virtual double prepare() = 0;
  virtual void apply_tangent(const double* d, double* out) = 0;
  virtual void diagonal_blocks(double* blocks) = 0;
  virtual double time_tangent_ms(int repeats) = 0;
  virtual double tangent_bytes() const = 0;
  virtual KernelResources tangent_kernel_resources() const = 0;
  virtual LaunchGrids launch_grids() const = 0;
  // Stepper.
  virtual void configure_step(const StepOptions& options) = 0;
  virtual StepReport step() = 0;
  virtual void last_increment(double* delta) const = 0;
  // Whether the configured persistent PCG is the resident kernel with staged frames.
  virtual bool resident_frames() const = 0;
  virtual double time_step_ms(int repeats) = 0;
  virtual double time_cg_iteration_ms(int repeats) = 0;

  DeviceOptions options;
  Design design = Design::fused;
  SamplePass pass = SamplePass::records;  // fused design
  bool staged = false;                    // pass == SamplePass::staged
  int lanes = 1;                          // fused design, records and lanes passes
  bool dense = false;                     // coalesced pass: the dense tangent kernel
  bool mapped = false;                    // coalesced pass: w and g from shape classes
  bool slot_frames = false;               // coalesced pass: the block's frames staged in shared memory
  bool direction_pass = false;            // coalesced pass, launched PCG: p formed by k_pcg_direction
  bool hold_pairs = false;                // coalesced pass: the dense kernel holds its kept pairs' levers
  bool prefetch_frames = false;           // coalesced pass: the dense kernel prefetches its next pairs' frames
  bool grouped = false;                   // coalesced pass: the launched tangent product runs the grouped pass
  bool group_mapped = false;              // ... with w and g from the groups' classes
  std::string mapped_refusal;             // why not, where DeviceOptions::shape_classes asked for them
  std::string grouped_refusal;            // why not, where DeviceOptions::group_samples asked for it
  std::string group_classes_refusal;      // why not, where DeviceOptions::group_classes asked for them
};

namespace {

template <class R>
class System final : public DeviceElasticity::Impl {
 public:
  System(const Model& input, const DeviceOptions& opts) {
    options = opts;
    FASCIA_CUDA(cudaStreamCreateWithFlags(&m_stream, cudaStreamNonBlocking));
    FASCIA_CUDA(cudaEventCreate(&m_start));
    FASCIA_CUDA(cudaEventCreate(&m_stop));
    validate(input);
    // The grouped pass needs each group's samples consecutive: group order, from the Morton order.
    const bool want_groups =
        opts.group_samples && opts.design == Design::fused && opts.sample_pass == SamplePass::coalesced;
    // Models whose groups average fewer than kMinGroupSamples samples are refused here, before
    // they are put in group order and their group layout is built.
    if (want_groups) grouped_refusal = group_refusal(input);
    bool group_order = want_groups && grouped_refusal.empty();
    std::vector<int> order;
    if (opts.reorder_samples) order = spatial_sample_order(input);
    if (group_order) {
      if (order.empty()) {
        order.resize(input.sample_count());
        std::iota(order.begin(), order.end(), 0);
      }
      double mean = 0;
      std::vector<int> grouped_order = group_sample_order(input, order, &mean);
      if (mean < kMinGroupSamples) {
        char text[160];
        std::snprintf(text, sizeof text,
                      "its groups of samples with the same frames average %.2f samples (at least %.0f needed)", mean,
                      kMinGroupSamples);
        grouped_refusal = text;
        group_order = false;
        if (!opts.reorder_samples) order.clear();
      } else {
        order = std::move(grouped_order);
      }
    }
    const Model model = order.empty() ? input : reorder_samples(input, order);
    design = opts.design;
    if (design == Design::fused && !offsets_are_rest_differences(model)) design = Design::paper;
    m_n = model.frame_count();
    m_s = model.sample_count();
    m_p = model.pair_count();
    m_locked = model.rotations_locked;
    m_max_neighbours = model.max_neighbours();
    m_row_frames = opts.row_frames;

    // Origin: centre of the rest bounding box of the frames.
    for (int k = 0; k < 3; ++k) {
      double lo = HUGE_VAL, hi = -HUGE_VAL;
      for (int i = 0; i < m_n; ++i) {
        lo = std::min(lo, model.frame_rest_positions[3 * i + k]);
        hi = std::max(hi, model.frame_rest_positions[3 * i + k]);
      }
      m_origin.x[k] = m_n > 0 ? 0.5 * (lo + hi) : 0.0;
    }
    std::vector<double> sample_rest = model.samples.rest_positions, frame_rest = model.frame_rest_positions;
    for (size_t k = 0; k < sample_rest.size(); ++k) sample_rest[k] -= m_origin.x[k % 3];
    for (size_t k = 0; k < frame_rest.size(); ++k) frame_rest[k] -= m_origin.x[k % 3];

    const NeighbourTable& nb = model.neighbours;
    m_offsets.upload(nb.offsets);
    m_frames.upload(nb.frames);
    m_weights.upload(nb.weights);
    m_gradients.upload(nb.weight_gradients);
    m_rest_offsets.upload(nb.rest_offsets);
    m_rev_offsets.upload(model.reverse.offsets);
    m_rev_pairs.upload(model.reverse.pairs);
    m_pair_samples.upload(model.reverse.pair_samples);
    m_volumes.upload(model.samples.volumes);
    m_sample_materials.upload(model.samples.materials);
    m_materials.upload(model.materials);
    m_sample_rest.upload(sample_rest);
    m_frame_rest.upload(frame_rest);
    std::vector<double> masses = model.frame_masses, inertias = model.frame_inertias;
    masses.resize(m_n, 0.0);
    inertias.resize(9 * static_cast<size_t>(m_n), 0.0);
    m_masses.upload(masses);
    m_inertias.upload(inertias);
    m_fixed.upload(model.fixed_dofs);

    if (design == Design::fused) {
      // At most kMappedSlots frames per block, so that the mapped pass's 1-byte block-local slot
      // index fits (rarely binding: 128 hexahedron samples touch about 50 frames).
      BlockLayout L = build_block_layout(model, opts.block_samples, kMaxBlockPairs, kMappedSlots);
      m_blocks = L.block_count();
      m_slots = L.slot_count();
      m_shared_bytes = static_cast<size_t>(L.max_block_pairs) * 6 * sizeof(R);
      m_block_samples.upload(L.block_samples);
      m_block_slots.upload(L.block_slots);
      m_slot_frames.upload(L.slot_frames);
      m_slot_pair_offsets.upload(L.slot_pair_offsets);
      m_slot_pairs.upload(L.slot_pairs);
      m_frame_slot_offsets.upload(L.frame_slot_offsets);
      m_frame_slots.upload(L.frame_slots);
      m_partials.resize(6 * static_cast<size_t>(m_slots));
      m_cache.resize(10 * static_cast<size_t>(m_s));
      // One thread per sample: the staged pass needs every sample of a block in one thread block.
      pass = opts.sample_pass;
      if (pass == SamplePass::staged &&
          !(opts.lanes <= 1 && opts.block_samples <= kLaneThreadsMax && upload_staged(model, L)))
        pass = SamplePass::lanes;
      if (pass == SamplePass::coalesced && !upload_coalesced(model, L)) pass = SamplePass::lanes;
      staged = pass == SamplePass::staged;
      m_lanes = staged ? 1 : pass_lanes(pass, opts.lanes, model.max_neighbours());
      lanes = m_lanes;
      if (pass == SamplePass::records) upload_records(model, sample_rest);
      // Coalesced pass: ELL entries kept per lane (more are read again): 2 in double, where 4
      // spills and was measured slower (DeviceOptions::coalesced_keep); in single the smaller of
      // 2 and 4 that holds the largest sample's pairs.
      m_keep = opts.record_keep;
      if (pass == SamplePass::coalesced) {
        const int per_lane = (model.max_neighbours() + m_lanes - 1) / m_lanes;
        m_keep = opts.coalesced_keep > 0                      ? opts.coalesced_keep
                 : per_lane <= 2 || std::is_same_v<R, double> ? 2
                                                              : 4;
      }
      m_lane_threads = staged ? opts.block_samples
                              : std::max(32, std::min({kLaneThreadsMax, opts.lane_threads, opts.block_samples * m_lanes}));
      dense = pass == SamplePass::coalesced && opts.dense_tangent && m_lane_threads == kDenseThreads;
      slot_frames = dense && !mapped && opts.slot_frames && m_slot_frame_bytes > 0;
      m_ell_tangent_bytes = slot_frames ? m_slot_frame_bytes : m_ell_bytes;
      direction_pass = pass == SamplePass::coalesced && opts.direction_pass;
      hold_pairs = dense && !mapped && !slot_frames && opts.hold_pairs && m_keep <= 4;
      prefetch_frames = dense && !mapped && !slot_frames && !hold_pairs && opts.prefetch_frames && m_keep <= 4;
      if (group_order) {
        if (pass != SamplePass::coalesced)
          grouped_refusal = "the coalesced pass is not in use";
        else {
          upload_groups(model);
          grouped = true;
        }
      }
      for (const void* k : {reinterpret_cast<const void*>(&k_records_tangent<R, 1, 128>),
                            reinterpret_cast<const void*>(&k_records_tangent<R, 2, 128>),
                            reinterpret_cast<const void*>(&k_records_tangent<R, 2, kLaneThreadsMax>)})
        FASCIA_CUDA(cudaFuncSetAttribute(k, cudaFuncAttributeMaxDynamicSharedMemorySize, static_cast<int>(m_shared_bytes)));
      const int max_shared = static_cast<int>(m_shared_bytes);
      FASCIA_CUDA(cudaFuncSetAttribute(k_lanes_tangent<R>, cudaFuncAttributeMaxDynamicSharedMemorySize, max_shared));
      FASCIA_CUDA(cudaFuncSetAttribute(k_fused_samples<Pass::gradient, R>, cudaFuncAttributeMaxDynamicSharedMemorySize,
                                       max_shared));
      FASCIA_CUDA(cudaFuncSetAttribute(k_fused_samples<Pass::tangent, R>, cudaFuncAttributeMaxDynamicSharedMemorySize,
                                       max_shared));
    } else {
      m_partials.resize(6 * static_cast<size_t>(m_p));
      m_cache.resize(10 * static_cast<size_t>(m_s));
      m_a.resize(3 * static_cast<size_t>(m_p));
    }

    m_view.samples = m_s;
    m_view.frames = m_n;
    m_view.pairs = m_p;
    m_view.offsets = m_offsets.data();
    m_view.frame_of = m_frames.data();
    m_view.weights = m_weights.data();
    m_view.gradients = m_gradients.data();
    m_view.rest_offsets = m_rest_offsets.data();
    m_view.rev_offsets = m_rev_offsets.data();
    m_view.rev_pairs = m_rev_pairs.data();
    m_view.pair_samples = m_pair_samples.data();
    m_view.volumes = m_volumes.data();
    m_view.sample_materials = m_sample_materials.data();
    m_view.materials = m_materials.data();
    m_view.sample_rest = m_sample_rest.data();
    m_view.frame_rest = m_frame_rest.data();
    m_view.masses = m_masses.data();
    m_view.inertias = m_inertias.data();
    m_view.fixed = m_fixed.data();
    m_view.rotations_locked = m_locked;
    m_view.blocks = m_blocks;
    m_view.block_samples = m_block_samples.data();
    m_view.block_slots = m_block_slots.data();
    m_view.slot_frames = m_slot_frames.data();
    m_view.slot_pair_offsets = m_slot_pair_offsets.data();
    m_view.slot_pairs = m_slot_pairs.data();
    m_view.frame_slot_offsets = m_frame_slot_offsets.data();
    m_view.frame_slots = m_frame_slots.data();
    m_view.ell_entries = m_ell_entries;
    m_view.ell_offsets = m_ell_offsets.data();
    m_view.ell_slot = m_ell_slot.data();
    m_view.ell_data = m_ell_data.data();
    m_view.slot_ell = m_slot_ell.data();
    m_view.ell_frame = m_ell_frame.data();
    m_view.ell_pos = m_ell_pos.data();
    m_view.ell_slot_rank = m_ell_slot_rank.data();
    m_view.shape_class = m_shape_class.data();
    m_view.shape_maps = m_shape_maps.data();
    m_view.class_offsets = m_class_offsets.data();
    m_view.class_pairs = m_class_pairs.data();
    m_view.pair_records = m_pair_records.data();
    m_view.sample_records = m_sample_records.data();
    if (grouped) {
      m_group_view = m_view;
      m_group_view.blocks = m_group_blocks;
      m_group_view.block_samples = nullptr;  // block b's groups are [kGroupBlock b, ...) (group_layout.hpp)
      m_group_view.block_slots = m_group_block_slots.data();
      m_group_view.slot_frames = nullptr;  // neither the grouped kernel nor k_frame_rows reads them
      m_group_view.slot_pair_offsets = m_group_slot_pair_offsets.data();
      m_group_view.slot_pairs = nullptr;
      m_group_view.frame_slot_offsets = m_group_frame_slot_offsets.data();
      m_group_view.frame_slots = nullptr;  // the partials are stored frame-major (slot_store)
      m_group_view.slot_store = m_group_slot_store.data();
      m_group_view.group_count = m_group_count;
      m_group_view.group_samples = m_group_samples.data();
      m_group_view.group_frames = m_group_frames.data();
      m_group_view.group_pos = m_group_pos.data();
      m_group_view.group_data = m_group_data.size() ? m_group_data.data() : nullptr;
      m_group_view.group_class = group_mapped ? m_group_class.data() : nullptr;
      m_group_view.group_maps = group_mapped ? m_group_maps.data() : nullptr;
      m_group_view.group_class_pairs = group_mapped ? m_group_class_pairs.data() : nullptr;
      m_group_view.group_entries = static_cast<long long>(m_group_data.size() / 4);
    }

    const size_t dofs = 6 * static_cast<size_t>(m_n);
    m_positions.resize(3 * static_cast<size_t>(m_n));
    m_orientations.resize(4 * static_cast<size_t>(m_n));
    m_velocities.resize(dofs);
    m_x.resize(3 * static_cast<size_t>(m_n));
    m_rot.resize(9 * static_cast<size_t>(m_n));
    m_F.resize(9 * static_cast<size_t>(m_s));
    m_geo.resize(9 * static_cast<size_t>(m_n));
    m_inertia_world.resize(9 * static_cast<size_t>(m_n));
    m_step_block.resize(9 * static_cast<size_t>(m_n));
    m_minv.resize(kMinvValues * static_cast<size_t>(m_n));
    m_diag.resize(36 * static_cast<size_t>(m_n));
    m_prepare_sums.resize(kPrepareSums * static_cast<size_t>(m_n));
    for (auto* v : {&m_grad, &m_d, &m_out, &m_cx, &m_cr, &m_cz, &m_cp, &m_cAp}) v->resize(dofs);
    // The partials and counters of every kernel that reduces (reduce_and_finish).
    const int max_grid = std::max({grid_for(m_s, kThreads), grid_for(m_n, kThreads), grid_for(m_n, m_row_frames),
                                   grid_for(6LL * m_n, kPaperGather), m_blocks, m_group_blocks, 1});
    m_red_partials.resize(reduce_partial_count(max_grid));
    m_counter.resize(reduce_counter_count(max_grid));
    m_counter.zero();
    m_scalars.resize(1);
    m_scalars.zero();
    // The launched row passes loop over their chunks (or frames) in the blocks that fit at once.
    const int chunks = grid_for(m_n, m_row_frames);
    m_rows_grid = options.frame_threads
                      ? resident_blocks(reinterpret_cast<const void*>(&k_frame_sums<R>), kFrameThreads,
                                        grid_for(m_n, kFrameThreads))
                      : resident_blocks(reinterpret_cast<const void*>(&k_frame_rows<R>), 6 * m_row_frames, chunks);
    m_update_grid = resident_blocks(reinterpret_cast<const void*>(&k_update_rows<R>), 6 * m_row_frames, chunks);
    if (options.row_blocks > 0) {
      m_rows_grid = std::min(m_rows_grid, options.row_blocks);
      m_update_grid = std::min(m_update_grid, options.row_blocks);
    }
    m_frame_view.rotations = m_rot.data();
    m_frame_view.positions = m_x.data();
    m_frame_view.records = m_records.size() ? m_records.data() : nullptr;
    m_frame_view.levers = m_levers.size() ? m_levers.data() : nullptr;
    m_frame_view.sample_state = m_sample_state.size() ? m_sample_state.data() : nullptr;
  }

  // Threads per sample when DeviceOptions::lanes is 0, measured on an H200 (docs/benchmarks.md).
  // records: enough lanes that each keeps at most kKeep pairs in registers; coalesced: one;
  // lanes: 2 in double above 4 neighbours, else 1.
  static int default_lanes(SamplePass pass, int neighbours) {
    if (pass == SamplePass::records) return (neighbours + kKeep - 1) / kKeep;
    if (pass == SamplePass::coalesced) return 1;
    return neighbours > 4 && sizeof(R) == sizeof(double) ? 2 : 1;
  }

  // Threads per sample of a lane-parallel pass: DeviceOptions::lanes (`requested`) or, where 0,
  // default_lanes, rounded up to a power of two, at most 32.
  static int pass_lanes(SamplePass pass, int requested, int neighbours) {
    const int wanted = requested > 0 ? std::min(requested, 32) : default_lanes(pass, neighbours);
    int lanes = 1;
    while (lanes < wanted) lanes *= 2;
    return lanes;
  }

  // The record pass's packed pair and sample records (kPairRecord, kSampleRecord) and the frame
  // records' storage (written by k_kinematics).
  void upload_records(const Model& model, const std::vector<double>& sample_rest) {
    const NeighbourTable& nb = model.neighbours;
    std::vector<double> pairs(kPairRecord * static_cast<size_t>(m_p)), samples(kSampleRecord * static_cast<size_t>(m_s));
    for (int p = 0; p < m_p; ++p) {
      for (int k = 0; k < 3; ++k) pairs[kPairRecord * static_cast<size_t>(p) + k] = nb.weight_gradients[3 * static_cast<size_t>(p) + k];
      pairs[kPairRecord * static_cast<size_t>(p) + 3] = nb.weights[p];
    }
    for (int t = 0; t < m_s; ++t) {
      for (int k = 0; k < 3; ++k) samples[kSampleRecord * static_cast<size_t>(t) + k] = sample_rest[3 * static_cast<size_t>(t) + k];
      samples[kSampleRecord * static_cast<size_t>(t) + 3] = model.samples.volumes[t];
    }
    m_pair_records.upload(pairs);
    m_sample_records.upload(samples);
    m_records.resize(kFrameRecord * static_cast<size_t>(m_n));
  }

  ~System() override {
    destroy_graphs();
    cudaEventDestroy(m_start);
    cudaEventDestroy(m_stop);
    cudaStreamDestroy(m_stream);
  }

  void set_state(const State& state) override {
    if (state.frame_count() != m_n) throw std::invalid_argument("DeviceElasticity: state has the wrong frame count");
    m_positions.upload(state.positions);
    m_orientations.upload(state.orientations);
    std::vector<double> v = state.velocities;
    v.resize(6 * static_cast<size_t>(m_n), 0.0);
    m_velocities.upload(v);
  }

  void get_state(State& state) const override {
    state.positions.resize(3 * static_cast<size_t>(m_n));
    state.orientations.resize(4 * static_cast<size_t>(m_n));
    state.velocities.resize(6 * static_cast<size_t>(m_n));
    m_positions.download(state.positions.data());
    m_orientations.download(state.orientations.data());
    m_velocities.download(state.velocities.data());
  }

  double energy() override {
    enqueue_gradient_pass(false);
    return read_scalars().energy;
  }

  double gradient(double* g) override {
    enqueue_gradient_pass(true);
    const double e = read_scalars().energy;
    m_grad.download(g);
    return e;
  }

  double prepare() override {
    enqueue_gradient_pass(false);
    enqueue_frame_prepare(0.0, true);
    return read_scalars().energy;
  }

  void apply_tangent(const double* d, double* out) override {
    m_d.upload(d, 6 * static_cast<size_t>(m_n));
    enqueue_tangent(m_d.data(), m_out.data(), FrameTermsFlags{0.0, false}, false);
    FASCIA_CUDA(cudaStreamSynchronize(m_stream));
    m_out.download(out);
  }

  void diagonal_blocks(double* blocks) override {
    FASCIA_CUDA(cudaStreamSynchronize(m_stream));
    m_diag.download(blocks);
  }

  double time_tangent_ms(int repeats) override {
    std::vector<double> d(6 * static_cast<size_t>(m_n));
    for (size_t k = 0; k < d.size(); ++k) d[k] = 1e-3 * std::sin(0.37 * static_cast<double>(k));
    m_d.upload(d);
    for (int k = 0; k < 3; ++k) enqueue_tangent(m_d.data(), m_out.data(), FrameTermsFlags{0.0, false}, false);
    FASCIA_CUDA(cudaEventRecord(m_start, m_stream));
    for (int k = 0; k < repeats; ++k) enqueue_tangent(m_d.data(), m_out.data(), FrameTermsFlags{0.0, false}, false);
    FASCIA_CUDA(cudaEventRecord(m_stop, m_stream));
    FASCIA_CUDA(cudaEventSynchronize(m_stop));
    float ms = 0;
    FASCIA_CUDA(cudaEventElapsedTime(&ms, m_start, m_stop));
    return ms / repeats;
  }

  double tangent_bytes() const override {
    const double r = sizeof(R), P = m_p, S = m_s, N = m_n;
    // Frames: rotation, position, d (read), out (write), geometric block (read), fixed flags.
    const double frames = N * (9 * r + 3 * r + 6 * r + 6 * r + 9 * r + 6);
    if (design == Design::fused && pass == SamplePass::records) {
      // Pair records and frame indices, sample records, offsets and materials, frame records
      // (instead of rotation and position), slot tables, slot partials out and in.
      const double Q = m_slots;
      return P * (4 * r + 4) + S * (4 * r + 4 + 4) + N * (16 * r - 12 * r) + Q * 4 * 2 + N * 4 + m_blocks * 8 +
             Q * 6 * r * 2 + frames;
    }
    if (design == Design::fused && grouped) {
      // Per pair w and g; per group its frames, entry positions and first sample; per sample its
      // state (StVK: 13 values), material and offset; lever records (instead of rotation and
      // position), read once per group but counted once; the slot tables of the blocks of groups
      // and their slot partials out and in.
      // Mapped: per group its class and map instead, and the classes' tables (counted once).
      const double Q = static_cast<double>(m_group_partials.size()) / 6, G = m_group_count;
      const double entries = group_mapped ? G * (9 * r + 4) + m_group_class_pairs.size() * r : P * 4 * r;
      return entries + G * (kGroupLanes * 6 + 4) + S * (13 * r + 4 + 4) + N * (kLeverRecord * r - 12 * r) + Q * 4 +
             N * 4 + m_group_blocks * 8 + Q * 6 * r * 2 + frames;
    }
    if (design == Design::fused && pass == SamplePass::coalesced) {
      // ELL entries (frame, w, g), per-sample state and offsets and materials, lever records
      // (instead of rotation and position), slot tables, slot partials out and in.
      // StVK reads 13 state values per sample (elasticity_phases.hpp, kSampleState).
      // Mapped: per entry its packed slot and rank, per sample A_s and its class, per slot its
      // table entry, and the class table (cache-resident, counted once).
      const double Q = m_slots, E = m_ell_entries;
      const double entries =
          mapped ? E * 2 + S * (9 * r + 4) + Q * 8 + m_class_pairs.size() * r : E * (4 * r + 4 + 2);
      return entries + S * (13 * r + 4 + 4) + N * (kLeverRecord * r - 12 * r) + Q * 4 + N * 4 + m_blocks * 12 +
             Q * 6 * r * 2 + frames;
    }
    if (design == Design::fused && staged) {
      const double Q = m_slots, E = m_ell_entries;
      return E * (4 * r + 2) + P * 4 + S * (3 * r + 9 * r + 10 * r + r + 4 + 4)  // ELL table, samples
             + Q * 4 + m_blocks * 12                                              // slot and block tables
             + Q * 6 * r * 2 + N * 4 + frames;  // slot partials out and in, frame slot lists
    }
    if (design == Design::fused) {
      const double Q = m_slots;
      return P * (4 + r + 3 * r) + S * (3 * r + r + 4 + 4 + 19 * r) + N * 3 * r  // tables, F, cache
             + P * 4 + Q * 4 * 2 + N * 4 + m_blocks * 8                  // slot tables
             + Q * 6 * r * 2 + frames;                                    // slot partials out and in
    }
    // Paper: pair table with a = R l, F and cache per sample, the pair buffer written and read.
    return P * (4 + r + 3 * r + 3 * r) + S * (9 * r + 10 * r + r + 4 + 4) + P * 6 * r * 2 + P * 4 + N * 4 + frames;
  }

  // The staged tangent pass's tables (build_ell_order) and shared-memory size; false, with
  // nothing uploaded, where its largest block would not fit in a thread block's shared memory.
  bool upload_staged(const Model& model, BlockLayout& L) {
    build_ell_order(model, L);
    size_t values = 0;
    for (int b = 0; b < L.block_count(); ++b) {
      const size_t ns = L.block_samples[b + 1] - L.block_samples[b];
      const size_t nq = L.block_slots[b + 1] - L.block_slots[b];
      const size_t Eb = L.ell_offsets[b + 1] - L.ell_offsets[b];
      values = std::max(values, kSlotStride * nq + std::max(kSampleStride * ns, 6 * Eb));
    }
    int shared_limit = 0, dev = 0;
    FASCIA_CUDA(cudaGetDevice(&dev));
    FASCIA_CUDA(cudaDeviceGetAttribute(&shared_limit, cudaDevAttrMaxSharedMemoryPerBlockOptin, dev));
    if (values * sizeof(R) > static_cast<size_t>(shared_limit)) return false;
    m_staged_bytes = values * sizeof(R);
    upload_ell(model, L, false);
    FASCIA_CUDA(cudaFuncSetAttribute(k_staged_tangent<R>, cudaFuncAttributeMaxDynamicSharedMemorySize,
                                     static_cast<int>(m_staged_bytes)));
    return true;
  }

  // The coalesced tangent pass's tables (build_ell_order, the entries' frames), the storage of
  // lever records and samples' state, and its shared-memory size (6 values per ELL entry of the
  // largest block); false, with nothing uploaded, where that would not fit in a thread block.
  bool upload_coalesced(const Model& model, BlockLayout& L) {
    // Positions interleaved for the lanes the pass will run.
    build_ell_order(model, L, pass_lanes(SamplePass::coalesced, options.lanes, model.max_neighbours()));
    const size_t pairs = static_cast<size_t>(L.max_block_pairs);
    int shared_limit = 0, dev = 0;
    FASCIA_CUDA(cudaGetDevice(&dev));
    FASCIA_CUDA(cudaDeviceGetAttribute(&shared_limit, cudaDevAttrMaxSharedMemoryPerBlockOptin, dev));
    if (6 * pairs * sizeof(R) > static_cast<size_t>(shared_limit) || pairs > 65535) return false;
    m_ell_bytes = 6 * pairs * sizeof(R);
    upload_ell(model, L, true);
    m_ell_pos.upload(std::vector<unsigned short>(L.ell_pos.begin(), L.ell_pos.end()));
    m_levers.resize(kLeverRecord * static_cast<size_t>(m_n));
    m_sample_state.resize(kSampleState * static_cast<size_t>(m_s));
    mapped = options.shape_classes && upload_shape_classes(model, L);
    // Slot frames: the slot records after the pair outputs (0 where they would not fit).
    int max_slots = 0;
    for (int b = 0; b < L.block_count(); ++b) max_slots = std::max(max_slots, L.block_slots[b + 1] - L.block_slots[b]);
    const size_t slot_bytes = (static_cast<size_t>(slot_records_offset(static_cast<int>(pairs))) +
                               kSlotFrameRecord * static_cast<size_t>(max_slots)) *
                              sizeof(R);
    m_slot_frame_bytes = slot_bytes <= static_cast<size_t>(shared_limit) ? slot_bytes : 0;
    // The resident kernel's staged frames (DeviceOptions::resident_frames) after the outputs: lever
    // records, directions and frame indices.
    const size_t lever_bytes = (static_cast<size_t>(slot_records_offset(static_cast<int>(pairs))) +
                                (kLeverRecord + 6) * static_cast<size_t>(max_slots)) *
                                   sizeof(R) +
                               sizeof(int) * static_cast<size_t>(max_slots);
    m_resident_frames_bytes = lever_bytes <= static_cast<size_t>(shared_limit) ? lever_bytes : 0;
    if (m_slot_frame_bytes > 0)
      for (int keep : {2, 4, 8})
        FASCIA_CUDA(cudaFuncSetAttribute(reinterpret_cast<const void*>(ell_tangent_kernel(keep, true, false, true)),
                                         cudaFuncAttributeMaxDynamicSharedMemorySize,
                                         static_cast<int>(m_slot_frame_bytes)));
    for (int keep : {2, 4, 8})
      for (bool dense_kernel : {false, true})
        for (bool mapped_kernel : {false, true})
          FASCIA_CUDA(cudaFuncSetAttribute(
              reinterpret_cast<const void*>(ell_tangent_kernel(keep, dense_kernel, mapped_kernel)),
              cudaFuncAttributeMaxDynamicSharedMemorySize, static_cast<int>(m_ell_bytes)));
    for (int keep : {2, 4})
      for (bool prefetch : {false, true})
        FASCIA_CUDA(cudaFuncSetAttribute(
            reinterpret_cast<const void*>(ell_tangent_kernel(keep, true, false, false, !prefetch, prefetch)),
            cudaFuncAttributeMaxDynamicSharedMemorySize, static_cast<int>(m_ell_bytes)));
    for (const void* k : {reinterpret_cast<const void*>(&k_pcg_two_barrier<R, 2>),
                          reinterpret_cast<const void*>(&k_pcg_two_barrier<R, 4>),
                          reinterpret_cast<const void*>(&k_pcg_two_barrier<R, 8>),
                          resident_kernel(4), resident_kernel(8)})
      FASCIA_CUDA(cudaFuncSetAttribute(k, cudaFuncAttributeMaxDynamicSharedMemorySize, static_cast<int>(m_ell_bytes)));
    return true;
  }

  // The grouped pass's tables (group_layout.hpp) for a model in group order whose groups average
  // kMinGroupSamples samples at least (the constructor refuses others): groups, their frames and
  // entry positions, w and g per (block, frame, thread), the slot tables of its blocks.
  void upload_groups(const Model& model) {
    const GroupLayout G = build_group_layout(model);
    const BlockLayout& L = G.slots;
    m_group_blocks = L.block_count();
    m_group_count = G.group_count();
    group_mapped = options.group_classes && upload_group_classes(model, G);
    if (!group_mapped) upload_group_data(model, G);
    m_group_samples.upload(G.group_samples);
    m_group_frames.upload(G.group_frames);
    m_group_pos.upload(std::vector<unsigned short>(G.entry_pos.begin(), G.entry_pos.end()));
    m_group_block_slots.upload(L.block_slots);
    m_group_slot_pair_offsets.upload(L.slot_pair_offsets);
    m_group_frame_slot_offsets.upload(L.frame_slot_offsets);
    m_group_slot_store.upload(G.slot_store);
    m_group_partials.resize(6 * static_cast<size_t>(L.slot_count()));
  }

  // The grouped pass's w and g per (block, frame, thread) entry (group_data_index,
  // group_data_offset: [E][4] in float, [4][E] in double).
  void upload_group_data(const Model& model, const GroupLayout& G) {
    const NeighbourTable& nb = model.neighbours;
    const BlockLayout& L = G.slots;
    const size_t E = static_cast<size_t>(m_group_blocks) * kGroupLanes * kGroupThreads;
    std::vector<double> data(4 * E, 0.0);
    for (int b = 0; b < m_group_blocks; ++b)
      for (int g = L.block_samples[b]; g < L.block_samples[b + 1]; ++g)
        for (int s = G.group_samples[g]; s < G.group_samples[g + 1]; ++s) {
          const int t = (g - L.block_samples[b]) * kGroupLanes + (s - G.group_samples[g]);
          for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) {
            const long long e = group_data_index(b, G.pair_entry[p], t), En = static_cast<long long>(E);
            data[group_data_offset<R>(e, 0, En)] = nb.weights[p];
            for (int k = 0; k < 3; ++k)
              data[group_data_offset<R>(e, k + 1, En)] = nb.weight_gradients[3 * static_cast<size_t>(p) + k];
          }
        }
    m_group_data.upload(data);
  }

  // The groups' classes and maps (group_classes.hpp) for the mapped grouped pass; false, with
  // nothing uploaded and the reason in group_classes_refusal, where the model has none, or so many
  // that they would not save memory traffic (more than one class per kGroupClassGroups groups).
  static constexpr int kMaxGroupClasses = 4096;
  static constexpr int kGroupClassGroups = 4;
  bool upload_group_classes(const Model& model, const GroupLayout& G) {
    std::string why;
    const std::optional<GroupClasses> classes = find_group_classes(model, G, kMaxGroupClasses, &why);
    if (!classes) {
      group_classes_refusal = why;
      return false;
    }
    if (static_cast<long long>(classes->class_count()) * kGroupClassGroups > G.group_count()) {
      group_classes_refusal = std::to_string(classes->class_count()) + " classes for " +
                              std::to_string(G.group_count()) + " groups";
      return false;
    }
    const size_t groups = static_cast<size_t>(G.group_count());
    std::vector<double> maps(9 * groups);  // component-major
    for (size_t g = 0; g < groups; ++g)
      for (int k = 0; k < 9; ++k) maps[k * groups + g] = classes->group_maps[9 * g + k];
    m_group_maps.upload(maps);
    m_group_class.upload(classes->group_class);
    m_group_class_pairs.upload(classes->class_pairs);
    return true;
  }

  // The samples' shape classes (shape_classes.hpp) for the mapped coalesced pass: per sample its
  // class and map A_s ([9][S]), per class its reference pairs, per ELL entry its block-local slot
  // and rank in the slot (1 byte each). False, with nothing uploaded, where the model has none, or
  // so many that they would not save memory traffic (more than one class per kShapeClassSamples
  // samples), or a block has more than kMappedSlots slots or a slot 256 pairs or more.
  static constexpr int kMaxShapeClasses = 4096;
  static constexpr int kShapeClassSamples = 4;
  bool upload_shape_classes(const Model& model, const BlockLayout& L) {
    std::vector<unsigned short> slot_rank(static_cast<size_t>(L.ell_count()), 0);
    for (int b = 0; b < L.block_count(); ++b) {
      const int q0 = L.block_slots[b], base = L.slot_pair_offsets[q0];
      if (L.block_slots[b + 1] - q0 > kMappedSlots) {
        mapped_refusal = "a thread block touches more than " + std::to_string(kMappedSlots) + " frames";
        return false;
      }
      for (int e = L.ell_offsets[b]; e < L.ell_offsets[b + 1]; ++e) {
        const int q = L.ell_slot[e], rank = L.ell_pos[e] - (L.slot_pair_offsets[q0 + q] - base);
        if (rank < 0 || rank > 255) {
          mapped_refusal = "a frame has 256 or more pairs in one thread block";
          return false;
        }
        slot_rank[e] = static_cast<unsigned short>(q | rank << 8);
      }
    }
    const std::optional<ShapeClasses> c = find_shape_classes(model.neighbours, kMaxShapeClasses);
    if (!c) {
      mapped_refusal = "the samples' weights and gradients fit no " + std::to_string(kMaxShapeClasses) +
                       " shape classes (as with meshless shape functions)";
      return false;
    }
    if (static_cast<long long>(c->class_count()) * kShapeClassSamples > m_s) {
      mapped_refusal = std::to_string(c->class_count()) + " shape classes for " + std::to_string(m_s) +
                       " samples: more than one per " + std::to_string(kShapeClassSamples);
      return false;
    }
    m_ell_slot_rank.upload(slot_rank);
    const size_t S = static_cast<size_t>(m_s);
    std::vector<double> maps(9 * S);
    for (size_t t = 0; t < S; ++t)
      for (size_t k = 0; k < 9; ++k) maps[k * S + t] = c->sample_maps[9 * t + k];
    m_shape_class.upload(c->sample_class);
    m_shape_maps.upload(maps);
    m_class_offsets.upload(c->class_offsets);
    m_class_pairs.upload(c->class_pairs);
    return true;
  }

  // The ELL tables of a layout with build_ell_order's order: entry offsets, slots, w and g
  // ([4][E]), and with `frames` each entry's frame.
  void upload_ell(const Model& model, const BlockLayout& L, bool frames) {
    const NeighbourTable& nb = model.neighbours;
    const int E = L.ell_count();
    std::vector<double> ell(4 * static_cast<size_t>(E), 0.0);  // [4][E]: w, g
    std::vector<int> ell_frame(frames ? E : 0, 0);
    for (int p = 0; p < model.pair_count(); ++p) {
      const int e = L.pair_ell[p];
      ell[e] = nb.weights[p];
      for (int k = 0; k < 3; ++k) ell[static_cast<size_t>(k + 1) * E + e] = nb.weight_gradients[3 * p + k];
      if (frames) ell_frame[e] = nb.frames[p];
    }
    m_ell_offsets.upload(L.ell_offsets);
    m_ell_slot.upload(L.ell_slot);
    m_slot_ell.upload(L.slot_ell);
    m_ell_data.upload(ell);
    if (frames) m_ell_frame.upload(ell_frame);
    m_ell_entries = E;
  }

  // ---- stepper -------------------------------------------------------------------------------

  void configure_step(const StepOptions& o) override {
    if (!(o.dt > 0)) throw std::invalid_argument("DeviceBackwardEuler: dt must be > 0 s");
    if (o.max_cg_iterations < 1) throw std::invalid_argument("DeviceBackwardEuler: max_cg_iterations must be >= 1");
    m_step = o;
    if (m_step.check_every < 1) m_step.check_every = 1;
    if (!o.external_forces.empty()) {
      if (o.external_forces.size() != 6 * static_cast<size_t>(m_n))
        throw std::invalid_argument("DeviceBackwardEuler: external_forces must be [N][6]");
      m_external.upload(o.external_forces);
    } else {
      m_external.resize(0);
    }
    if (!o.load_rotational_blocks.empty()) {
      if (o.load_rotational_blocks.size() != 9 * static_cast<size_t>(m_n))
        throw std::invalid_argument("DeviceBackwardEuler: load_rotational_blocks must be [N][9]");
      m_load_rot.upload(o.load_rotational_blocks);
    } else {
      m_load_rot.resize(0);
    }
    if (o.rayleigh_mass < 0 || o.rayleigh_stiffness < 0)
      throw std::invalid_argument("DeviceBackwardEuler: Rayleigh coefficients must be >= 0");
    m_persistent_grid = o.persistent ? persistent_grid() : 0;
    if (m_red_partials.size() < 2 * static_cast<size_t>(m_persistent_grid)) {
      m_red_partials.resize(2 * static_cast<size_t>(m_persistent_grid));
    }
    destroy_graphs();
  }

  StepReport step() override {
    const bool fixed_count = m_step.cg_tolerance <= 0;
    if (use_persistent()) {
      if (m_step.use_graphs) {
        launch_graph(m_graph_begin, [&] { enqueue_step_begin(); });
        enqueue_persistent_pcg();
        launch_graph(m_graph_end, [&] { enqueue_step_end(); });
      } else {
        enqueue_step_begin();
        enqueue_persistent_pcg();
        enqueue_step_end();
      }
    } else if (m_step.use_graphs) {
      if (fixed_count) {
        launch_graph(m_graph_full, [&] {
          enqueue_step_begin();
          for (int k = 0; k < m_step.max_cg_iterations; ++k) enqueue_cg_iteration();
          enqueue_step_end();
        });
      } else {
        launch_graph(m_graph_begin, [&] { enqueue_step_begin(); });
        run_tolerance_loop();
        launch_graph(m_graph_end, [&] { enqueue_step_end(); });
      }
    } else {
      enqueue_step_begin();
      if (fixed_count)
        for (int k = 0; k < m_step.max_cg_iterations; ++k) enqueue_cg_iteration();
      else
        run_tolerance_loop();
      enqueue_step_end();
    }
    const Scalars sc = read_scalars();
    StepReport report;
    report.persistent = use_persistent();
    report.resident = use_persistent() && m_resident;
    report.cg_iterations = sc.iterations;
    report.cg_relative_residual = sc.rz0 > 0 ? std::sqrt(std::max(0.0, sc.rz) / sc.rz0) : 0.0;
    report.energy = sc.energy;
    return report;
  }

  void last_increment(double* delta) const override {
    FASCIA_CUDA(cudaStreamSynchronize(m_stream));
    m_cx.download(delta);
  }

  double time_step_ms(int repeats) override {
    for (int k = 0; k < 2; ++k) step();
    FASCIA_CUDA(cudaEventRecord(m_start, m_stream));
    for (int k = 0; k < repeats; ++k) {
      if (use_persistent()) {
        if (m_step.use_graphs) {
          FASCIA_CUDA(cudaGraphLaunch(m_graph_begin, m_stream));
          enqueue_persistent_pcg();
          FASCIA_CUDA(cudaGraphLaunch(m_graph_end, m_stream));
        } else {
          enqueue_step_begin();
          enqueue_persistent_pcg();
          enqueue_step_end();
        }
      } else if (m_step.use_graphs && m_step.cg_tolerance <= 0) {
        FASCIA_CUDA(cudaGraphLaunch(m_graph_full, m_stream));
      } else {
        enqueue_step_begin();
        for (int j = 0; j < m_step.max_cg_iterations; ++j) enqueue_cg_iteration();
        enqueue_step_end();
      }
    }
    FASCIA_CUDA(cudaEventRecord(m_stop, m_stream));
    FASCIA_CUDA(cudaEventSynchronize(m_stop));
    float ms = 0;
    FASCIA_CUDA(cudaEventElapsedTime(&ms, m_start, m_stop));
    return ms / repeats;
  }

  double time_cg_iteration_ms(int repeats) override {
    const int iterations = m_step.max_cg_iterations;
    if (!use_persistent())
      launch_graph(m_graph_iterations, [&] {
        for (int k = 0; k < iterations; ++k) enqueue_cg_iteration();
      });
    double total = 0;
    for (int k = 0; k < repeats + 1; ++k) {
      enqueue_step_begin();
      FASCIA_CUDA(cudaEventRecord(m_start, m_stream));
      if (use_persistent())
        enqueue_persistent_pcg();
      else
        FASCIA_CUDA(cudaGraphLaunch(m_graph_iterations, m_stream));
      FASCIA_CUDA(cudaEventRecord(m_stop, m_stream));
      FASCIA_CUDA(cudaEventSynchronize(m_stop));
      float ms = 0;
      FASCIA_CUDA(cudaEventElapsedTime(&ms, m_start, m_stop));
      if (k > 0) total += ms;  // the first is the warm-up
    }
    return total / (repeats * static_cast<double>(iterations));
  }

 private:
  Reduction reduction() { return Reduction{m_red_partials.data(), m_counter.data(), m_scalars.data()}; }

  Scalars read_scalars() {
    Scalars sc{};
    FASCIA_CUDA(cudaMemcpyAsync(&sc, m_scalars.data(), sizeof(Scalars), cudaMemcpyDeviceToHost, m_stream));
    FASCIA_CUDA(cudaStreamSynchronize(m_stream));
    return sc;
  }

  void check_launch() { FASCIA_CUDA(cudaGetLastError()); }

  // Kinematics and the force pass: energy into the scalars, gradient into m_grad when `gather`
  // (always for the fused design's F), F (and the paper's cache and a) stored.
  void enqueue_gradient_pass(bool gather) {
    k_kinematics<R><<<grid_for(m_n, kThreads), kThreads, 0, m_stream>>>(m_n, m_positions.data(), m_orientations.data(),
                                                                         m_origin, m_x.data(), m_rot.data(),
                                                                         m_frame_rest.data(),
                                                                         m_records.size() ? m_records.data() : nullptr,
                                                                         m_levers.size() ? m_levers.data() : nullptr);
    check_launch();
    const FrameTermsFlags none{0.0, false};
    if (design == Design::fused) {
      // The coalesced pass's sample state is packed by the same kernel.
      k_fused_samples<Pass::gradient, R><<<m_blocks, options.block_samples, m_shared_bytes, m_stream>>>(
          m_view, m_frame_view, nullptr, m_F.data(), m_cache.data(), m_partials.data(), reduction(), nullptr,
          pass == SamplePass::coalesced ? m_sample_state.data() : nullptr);
      check_launch();
      if (gather) {
        enqueue_frame_rows(m_view, m_partials.data(), nullptr, nullptr, none, nullptr, m_grad.data(), false, nullptr);
      }
    } else {
      k_paper_gradient<R><<<grid_for(m_s, kThreads), kThreads, 0, m_stream>>>(
          m_view, m_frame_view, m_F.data(), m_cache.data(), m_a.data(), m_partials.data(), reduction());
      check_launch();
      if (gather) {
        k_paper_gather<R><<<grid_for(6LL * m_n, kPaperGather), kPaperGather, 0, m_stream>>>(
            m_view, m_partials.data(), nullptr, nullptr, none, m_d.data(), m_grad.data(), reduction(), false);
        check_launch();
      }
    }
  }

  void enqueue_frame_prepare(double inv_h2, bool diag, double k_scale = 1.0, const double* load_rot = nullptr,
                             bool precondition = true) {
    k_frame_columns<R><<<grid_for(m_n, kColumnFrames), kColumnParts * kColumnFrames, 0, m_stream>>>(
        m_view, m_frame_view, m_F.data(), design == Design::fused, precondition || diag, m_prepare_sums.data());
    check_launch();
    k_frame_finish<R><<<grid_for(m_n, kFinishFrames), 6 * kFinishFrames, 0, m_stream>>>(
        m_view, m_frame_view, m_prepare_sums.data(), inv_h2, m_geo.data(), m_inertia_world.data(), m_minv.data(),
        diag ? m_diag.data() : nullptr, k_scale, load_rot, precondition, m_step_block.data());
    check_launch();
  }

  // Step operator flags: H = k_scale K + inv_h2 M (+ load blocks in m_geo), fixed DOFs projected.
  FrameTermsFlags step_flags() const {
    const double h = m_step.dt;
    return FrameTermsFlags{(1.0 + m_step.rayleigh_mass * h) / (h * h), true, 1.0 + m_step.rayleigh_stiffness / h};
  }

  // The frame terms of the launched frame pass: in the PCG the step's rotational block with the
  // inertia added (m_step_block, k_frame_finish: k_scale Kr + L + (1 + alpha h)/h^2 R I_0 R^T, 9
  // values per frame instead of 18) and no inertia; else the rotational block and the inertia.
  const R* frame_block(bool pcg) const { return pcg ? m_step_block.data() : m_geo.data(); }
  const R* frame_inertia(bool pcg) const { return pcg ? nullptr : m_inertia_world.data(); }

  // The frame pass of the launched tangent product (k_frame_rows, or k_frame_sums with
  // DeviceOptions::frame_threads): out = H d from the slot partials and the frame terms; in the
  // PCG (`pcg`) also alpha, with p = z + beta p formed where z is set.
  void enqueue_frame_rows(const ModelView<R>& view, const R* partials, const R* geo, const R* inertia,
                          FrameTermsFlags flags, R* d, R* out, bool pcg, const R* z) {
    if (options.frame_threads)
      k_frame_sums<R><<<m_rows_grid, kFrameThreads, 0, m_stream>>>(view, partials, geo, inertia, flags, d, out,
                                                                   reduction(), pcg, z);
    else
      k_frame_rows<R><<<m_rows_grid, 6 * m_row_frames, 0, m_stream>>>(view, partials, geo, inertia, flags, d, out,
                                                                      reduction(), pcg, z);
    check_launch();
  }

  // The launched tangent product's sample kernel in use (enqueue_tangent's choice).
  const void* tangent_sample_kernel() const {
    if (design != Design::fused) return reinterpret_cast<const void*>(&k_paper_tangent<R>);
    if (grouped)
      return group_mapped ? reinterpret_cast<const void*>(&k_group_tangent<R, true>)
                          : reinterpret_cast<const void*>(&k_group_tangent<R, false>);
    if (pass == SamplePass::coalesced) return reinterpret_cast<const void*>(ell_tangent_kernel());
    if (pass == SamplePass::records) {
      if (m_lane_threads > 128) return reinterpret_cast<const void*>(&k_records_tangent<R, 2, kLaneThreadsMax>);
      if (options.record_keep == 1) return reinterpret_cast<const void*>(&k_records_tangent<R, 1, 128>);
      return reinterpret_cast<const void*>(&k_records_tangent<R, 2, 128>);
    }
    if (staged) return reinterpret_cast<const void*>(&k_staged_tangent<R>);
    return reinterpret_cast<const void*>(&k_lanes_tangent<R>);
  }

  LaunchGrids launch_grids() const override {
    const int chunks = grid_for(m_n, m_row_frames);
    return LaunchGrids{options.frame_threads ? grid_for(m_n, kFrameThreads) : chunks, chunks, m_rows_grid,
                       m_update_grid, kReduceChunk};
  }

  KernelResources tangent_kernel_resources() const override {
    cudaFuncAttributes attr{};
    FASCIA_CUDA(cudaFuncGetAttributes(&attr, tangent_sample_kernel()));
    return KernelResources{attr.numRegs, static_cast<long long>(attr.localSizeBytes)};
  }

  // out = (K + M/h^2) d with the given flags; in the PCG (`pcg`) also alpha = rz / d.out.
  // Fused design in the PCG: d is the direction p, first set to z + beta p (z = m_cz).
  void enqueue_tangent(R* d, R* out, FrameTermsFlags flags, bool pcg) {
    const Scalars* sc = pcg ? m_scalars.data() : nullptr;
    if (design == Design::fused) {
      // With the direction pass p is already formed: the passes read it instead of z and p.
      const R* z = pcg && !direction_pass ? m_cz.data() : nullptr;
      if (grouped) {
        const R* pd = z ? z : d;
        const R* pold = z ? d : nullptr;
        (group_mapped ? k_group_tangent<R, true> : k_group_tangent<R, false>)<<<m_group_blocks, kGroupThreads, 0,
                                                                             m_stream>>>(
            m_group_view, m_frame_view, pd, pold, m_group_partials.data(), sc, options.slot_lanes);
        check_launch();
        enqueue_frame_rows(m_group_view, m_group_partials.data(), frame_block(pcg), frame_inertia(pcg), flags, d, out,
                           pcg, z);
        return;
      }
      if (pass == SamplePass::coalesced) {
        const R* pd = z ? z : d;
        const R* pold = z ? d : nullptr;
        ell_tangent_kernel()<<<m_blocks, m_lane_threads, m_ell_tangent_bytes, m_stream>>>(
            m_view, m_frame_view, pd, pold, m_partials.data(), sc, m_lanes, options.slot_lanes);
      } else if (pass == SamplePass::records) {
        const R* pd = pcg ? z : d;
        const R* pold = pcg ? d : nullptr;
        if (m_lane_threads > 128)
          k_records_tangent<R, 2, kLaneThreadsMax><<<m_blocks, m_lane_threads, m_shared_bytes, m_stream>>>(
              m_view, m_frame_view, pd, pold, m_partials.data(), sc, m_lanes);
        else if (options.record_keep == 1)
          k_records_tangent<R, 1, 128><<<m_blocks, m_lane_threads, m_shared_bytes, m_stream>>>(
              m_view, m_frame_view, pd, pold, m_partials.data(), sc, m_lanes);
        else
          k_records_tangent<R, 2, 128><<<m_blocks, m_lane_threads, m_shared_bytes, m_stream>>>(
              m_view, m_frame_view, pd, pold, m_partials.data(), sc, m_lanes);
      }
      else if (staged)
        k_staged_tangent<R><<<m_blocks, m_lane_threads, m_staged_bytes, m_stream>>>(
            m_view, m_frame_view, m_F.data(), m_cache.data(), pcg ? z : d, pcg ? d : nullptr, m_partials.data(), sc);
      else
        k_lanes_tangent<R><<<m_blocks, m_lane_threads, m_shared_bytes, m_stream>>>(
            m_view, m_frame_view, m_F.data(), m_cache.data(), pcg ? z : d, pcg ? d : nullptr, m_partials.data(), sc,
            m_lanes);
      check_launch();
      enqueue_frame_rows(m_view, m_partials.data(), frame_block(pcg), frame_inertia(pcg), flags, d, out, pcg, z);
    } else {
      k_paper_tangent<R><<<grid_for(m_s, kThreads), kThreads, 0, m_stream>>>(
          m_view, m_frame_view, m_F.data(), m_cache.data(), m_a.data(), d, m_partials.data(), sc);
      check_launch();
      k_paper_gather<R><<<grid_for(6LL * m_n, kPaperGather), kPaperGather, 0, m_stream>>>(
          m_view, m_partials.data(), m_geo.data(), m_inertia_world.data(), flags, d, out, reduction(), pcg);
    }
    check_launch();
  }

  void enqueue_step_begin() {
    const double h = m_step.dt;
    const FrameTermsFlags flags = step_flags();
    enqueue_gradient_pass(true);
    enqueue_frame_prepare(flags.inv_h2, false, flags.k_scale, m_load_rot.size() ? m_load_rot.data() : nullptr,
                          m_step.preconditioner);
    k_pcg_init<R><<<grid_for(m_n, kThreads), kThreads, 0, m_stream>>>(
        m_view, m_grad.data(), m_inertia_world.data(), m_velocities.data(),
        m_external.size() ? m_external.data() : nullptr, 1.0 / h, m_minv.data(), m_cx.data(), m_cr.data(), m_cz.data(),
        m_cp.data(), reduction());
    check_launch();
  }

  void enqueue_cg_iteration() {
    enqueue_tangent(m_cp.data(), m_cAp.data(), step_flags(), true);
    k_update_rows<R><<<m_update_grid, 6 * m_row_frames, 0, m_stream>>>(
        m_n, m_minv.data(), m_cp.data(), m_cAp.data(), m_cx.data(), m_cr.data(), m_cz.data(), reduction(),
        m_step.cg_tolerance);
    check_launch();
    if (design != Design::fused || direction_pass) {  // else the fused passes form p = z + beta p themselves
      k_pcg_direction<R><<<grid_for(6LL * m_n, kThreads), kThreads, 0, m_stream>>>(6 * m_n, m_cz.data(), m_cp.data(),
                                                                                    m_scalars.data());
      check_launch();
    }
  }

  // The PCG loop as one cooperative kernel (k_pcg_persistent), up to max_cg_iterations.
  void enqueue_persistent_pcg() {
    ModelView<R> view = m_view;
    FrameView<R> frames = m_frame_view;
    const R* F = m_F.data();
    const R* cache = m_cache.data();
    int lanes = m_lanes;
    SamplePass use_pass = pass;
    const R* geo = m_geo.data();
    const R* inertia = m_inertia_world.data();
    FrameTermsFlags flags = step_flags();
    const R* minv = m_minv.data();
    R *x = m_cx.data(), *r = m_cr.data(), *z = m_cz.data(), *p = m_cp.data(), *Ap = m_cAp.data();
    R* slots = m_partials.data();
    double* partials = m_red_partials.data();
    Scalars* scalars = m_scalars.data();
    int iterations = m_step.max_cg_iterations;
    double tolerance = m_step.cg_tolerance;
    if (m_resident) {
      void* args[] = {&view, &frames, &geo, &inertia, &flags, &minv, &x, &r, &z, &p, &Ap,
                      &slots, &partials, &scalars, &iterations, &tolerance};
      FASCIA_CUDA(cudaLaunchCooperativeKernel(persistent_kernel(), dim3(m_persistent_grid), dim3(m_lane_threads), args,
                                              persistent_shared_bytes(), m_stream));
      return;
    }
    if (pass == SamplePass::coalesced) {
      int slot_lanes = options.slot_lanes;
      void* args[] = {&view, &frames, &lanes, &slot_lanes, &geo, &inertia, &flags, &minv, &x, &r, &z, &p, &Ap,
                      &slots, &partials, &scalars, &iterations, &tolerance};
      FASCIA_CUDA(cudaLaunchCooperativeKernel(persistent_kernel(), dim3(m_persistent_grid), dim3(m_lane_threads), args,
                                              persistent_shared_bytes(), m_stream));
      return;
    }
    void* args[] = {&view, &frames, &F, &cache, &lanes, &use_pass, &geo, &inertia, &flags, &minv, &x, &r, &z, &p, &Ap,
                    &slots, &partials, &scalars, &iterations, &tolerance};
    FASCIA_CUDA(cudaLaunchCooperativeKernel(persistent_kernel(), dim3(m_persistent_grid), dim3(m_lane_threads), args,
                                            persistent_shared_bytes(), m_stream));
  }

  bool use_persistent() const { return m_step.persistent && m_persistent_grid > 0; }
  size_t persistent_shared_bytes() const {
    if (m_resident && resident_staged()) return m_resident_frames_bytes;
    return staged ? m_staged_bytes : pass == SamplePass::coalesced ? m_ell_bytes : m_shared_bytes;
  }

  // The coalesced tangent kernel for `keep` held entries (2, 4, else 8), dense or not, mapped or
  // not; without arguments the one in use (m_keep, Impl::dense, Impl::mapped).
  using EllTangentKernel = void (*)(ModelView<R>, FrameView<R>, const R*, const R*, R*, const Scalars*, int, int);
  template <bool Dense, bool Mapped>
  static EllTangentKernel ell_tangent_kernel(int keep) {
    return keep == 2   ? &k_ell_tangent<R, 2, Dense, Mapped>
           : keep == 4 ? &k_ell_tangent<R, 4, Dense, Mapped>
                       : &k_ell_tangent<R, 8, Dense, Mapped>;
  }
  static EllTangentKernel ell_tangent_kernel(int keep, bool dense_kernel, bool mapped_kernel,
                                             bool slot_frames_kernel = false, bool hold_pairs_kernel = false,
                                             bool prefetch_frames_kernel = false) {
    if (hold_pairs_kernel)  // keep 2 or 4
      return keep == 2 ? &k_ell_tangent<R, 2, true, false, false, true> : &k_ell_tangent<R, 4, true, false, false, true>;
    if (prefetch_frames_kernel)  // keep 2 or 4
      return keep == 2 ? &k_ell_tangent<R, 2, true, false, false, false, true>
                       : &k_ell_tangent<R, 4, true, false, false, false, true>;
    if (slot_frames_kernel)
      return keep == 2   ? &k_ell_tangent<R, 2, true, false, true>
             : keep == 4 ? &k_ell_tangent<R, 4, true, false, true>
                         : &k_ell_tangent<R, 8, true, false, true>;
    if (dense_kernel)
      return mapped_kernel ? ell_tangent_kernel<true, true>(keep) : ell_tangent_kernel<true, false>(keep);
    return mapped_kernel ? ell_tangent_kernel<false, true>(keep) : ell_tangent_kernel<false, false>(keep);
  }
  EllTangentKernel ell_tangent_kernel() const {
    return ell_tangent_kernel(m_keep, dense, mapped, slot_frames, hold_pairs, prefetch_frames);
  }

  // k_pcg_resident for samples of at most `pairs` (4 or 8) pairs; the invariants in registers in
  // single precision, partly in shared memory in double (in registers they would not leave room
  // for three blocks per multiprocessor).
  // Staged: the double kernel for 4 pairs with the slots' lever records and directions in shared
  // memory (DeviceOptions::resident_frames). The single kernel, which holds its levers in
  // registers, staging the directions alone was measured no faster (docs/benchmarks.md, eighth
  // round), so single precision does not use it.
  static const void* resident_kernel(int pairs, bool staged = false) {
    constexpr bool in_registers = sizeof(R) == sizeof(float);
    if (staged && !in_registers && pairs <= 4)
      return reinterpret_cast<const void*>(&k_pcg_resident<R, 4, in_registers, !in_registers>);
    return pairs <= 4 ? reinterpret_cast<const void*>(&k_pcg_resident<R, 4, in_registers>)
                      : reinterpret_cast<const void*>(&k_pcg_resident<R, 8, in_registers>);
  }
  bool resident_staged() const {
    return std::is_same_v<R, double> && options.resident_frames && m_max_neighbours <= 4 &&
           m_resident_frames_bytes > 0 && m_resident_try_staged;
  }
  bool resident_frames() const override { return use_persistent() && m_resident && resident_staged(); }

  // The persistent PCG kernel of the sample pass in use: k_pcg_resident or k_pcg_two_barrier
  // (two grid barriers per iteration) for the coalesced pass, k_pcg_persistent (three) otherwise.
  const void* persistent_kernel() const {
    if (m_resident) return resident_kernel(m_max_neighbours, resident_staged());
    if (pass != SamplePass::coalesced) return reinterpret_cast<const void*>(&k_pcg_persistent<R>);
    if (m_keep == 2) return reinterpret_cast<const void*>(&k_pcg_two_barrier<R, 2>);
    if (m_keep == 4) return reinterpret_cast<const void*>(&k_pcg_two_barrier<R, 4>);
    return reinterpret_cast<const void*>(&k_pcg_two_barrier<R, 8>);
  }

  // Blocks of `kernel` (`threads` each) that fit on the device at once, at most `blocks`.
  static int resident_blocks(const void* kernel, int threads, int blocks) {
    int dev = 0, sms = 0, per_sm = 0;
    FASCIA_CUDA(cudaGetDevice(&dev));
    FASCIA_CUDA(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, dev));
    FASCIA_CUDA(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, kernel, threads, 0));
    return std::max(1, std::min(blocks, std::max(1, per_sm) * sms));
  }

  // Grid of the persistent PCG: every block resident (cooperative launch), no more blocks than
  // sample blocks or frame blocks need. 0 where it cannot run (paper design, no cooperative launch).
  int persistent_grid() {
    m_resident = false;
    if (design != Design::fused) return 0;
    int dev = 0, coop = 0, sms = 0, per_sm = 0;
    FASCIA_CUDA(cudaGetDevice(&dev));
    FASCIA_CUDA(cudaDeviceGetAttribute(&coop, cudaDevAttrCooperativeLaunch, dev));
    FASCIA_CUDA(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, dev));
    if (!coop) return 0;
    // Resident: one block per sample block and per frame chunk, all co-resident.
    if (pass == SamplePass::coalesced && options.resident && m_lanes == 1 && m_max_neighbours <= 8 &&
        m_lane_threads == kResidentThreads) {
      const int wanted = std::max(m_blocks, grid_for(m_n, m_lane_threads / 6));
      m_resident = true;
      // In double only with DeviceOptions::resident_double and where the compiled kernel needs no
      // local memory (4 pairs per sample; with 8 it spills): one that spilled was measured slower
      // than k_pcg_two_barrier on an H100 (docs/benchmarks.md). Its static shared memory (double)
      // plus the pair outputs can pass 48 KB, hence the opt-in before the occupancy query. With
      // staged lever records (DeviceOptions::resident_frames) first, then without, where the
      // larger shared memory leaves too few blocks per multiprocessor.
      for (bool try_staged : {true, false}) {
        m_resident_try_staged = try_staged;
        cudaFuncAttributes attr{};
        FASCIA_CUDA(cudaFuncGetAttributes(&attr, persistent_kernel()));
        FASCIA_CUDA(cudaFuncSetAttribute(persistent_kernel(), cudaFuncAttributeMaxDynamicSharedMemorySize,
                                         static_cast<int>(persistent_shared_bytes())));
        FASCIA_CUDA(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, persistent_kernel(), m_lane_threads,
                                                                  persistent_shared_bytes()));
        if ((sizeof(R) == sizeof(float) || (options.resident_double && attr.localSizeBytes == 0)) && per_sm > 0 &&
            wanted <= per_sm * sms && wanted <= options.persistent_blocks_per_sm * sms)
          return wanted;
      }
      m_resident = false;
    }
    FASCIA_CUDA(cudaFuncSetAttribute(persistent_kernel(), cudaFuncAttributeMaxDynamicSharedMemorySize,
                                     static_cast<int>(persistent_shared_bytes())));
    FASCIA_CUDA(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, persistent_kernel(), m_lane_threads,
                                                              persistent_shared_bytes()));
    if (per_sm < 1) return 0;
    // Only for small grids (grid barriers and every block's sum of all partials grow with the
    // grid): DeviceOptions::persistent_blocks_per_sm, measured on an H200 (docs/benchmarks.md).
    const int wanted = std::max(m_blocks, grid_for(m_n, m_lane_threads / 6));
    if (wanted > options.persistent_blocks_per_sm * sms) return 0;
    return std::max(1, std::min(wanted, per_sm * sms));
  }

  void enqueue_step_end() {
    k_step_update<R><<<grid_for(m_n, kThreads), kThreads, 0, m_stream>>>(
        m_n, m_locked, 1.0 / m_step.dt, m_cx.data(), m_positions.data(), m_orientations.data(), m_velocities.data());
    check_launch();
  }

  // Runs the PCG in chunks of check_every iterations (graphs when enabled), reading the flag once
  // per chunk: no host round trip per iteration.
  void run_tolerance_loop() {
    int done_iterations = 0;
    while (done_iterations < m_step.max_cg_iterations) {
      const int chunk = std::min(m_step.check_every, m_step.max_cg_iterations - done_iterations);
      if (m_step.use_graphs) {
        cudaGraphExec_t& g = chunk == m_step.check_every ? m_graph_chunk : m_graph_tail;
        launch_graph(g, [&] {
          for (int k = 0; k < chunk; ++k) enqueue_cg_iteration();
        });
      } else {
        for (int k = 0; k < chunk; ++k) enqueue_cg_iteration();
      }
      done_iterations += chunk;
      if (read_scalars().done) break;
    }
  }

  template <class Body>
  void launch_graph(cudaGraphExec_t& exec, Body body) {
    if (!exec) {
      cudaGraph_t graph = nullptr;
      FASCIA_CUDA(cudaStreamBeginCapture(m_stream, cudaStreamCaptureModeThreadLocal));
      body();
      FASCIA_CUDA(cudaStreamEndCapture(m_stream, &graph));
      FASCIA_CUDA(cudaGraphInstantiate(&exec, graph, 0));
      FASCIA_CUDA(cudaGraphDestroy(graph));
    }
    FASCIA_CUDA(cudaGraphLaunch(exec, m_stream));
  }

  void destroy_graphs() {
    for (cudaGraphExec_t* g : {&m_graph_full, &m_graph_begin, &m_graph_end, &m_graph_chunk, &m_graph_tail,
                               &m_graph_iterations}) {
      if (*g) cudaGraphExecDestroy(*g);
      *g = nullptr;
    }
  }

  int m_row_frames = 42;
  // Grids of the launched row passes (k_frame_rows, k_update_rows): the blocks that fit at once
  // (resident_blocks).
  int m_rows_grid = 1, m_update_grid = 1;
  int m_n = 0, m_s = 0, m_p = 0, m_blocks = 0, m_slots = 0, m_persistent_grid = 0, m_lanes = 1, m_lane_threads = 128;
  bool m_locked = false;
  int m_ell_entries = 0, m_keep = 2, m_max_neighbours = 0;
  bool m_resident = false;  // the persistent PCG is k_pcg_resident
  size_t m_shared_bytes = 0, m_staged_bytes = 0, m_ell_bytes = 0;
  size_t m_slot_frame_bytes = 0;   // the slot-frames kernel's: pair outputs and slot records
  size_t m_resident_frames_bytes = 0;  // the resident double kernel's with staged frames
  bool m_resident_try_staged = true;   // persistent_grid: the staged kernel is still a candidate
  size_t m_ell_tangent_bytes = 0;  // the launched coalesced tangent kernel's
  Origin m_origin{};
  cudaStream_t m_stream = nullptr;
  cudaEvent_t m_start = nullptr, m_stop = nullptr;
  ModelView<R> m_view;
  ModelView<R> m_group_view;  // the grouped pass's: m_view with its blocks of groups and their slots
  FrameView<R> m_frame_view;
  StepOptions m_step;
  cudaGraphExec_t m_graph_full = nullptr, m_graph_begin = nullptr, m_graph_end = nullptr, m_graph_chunk = nullptr,
                  m_graph_tail = nullptr, m_graph_iterations = nullptr;

  // Model.
  DeviceBuffer<int> m_offsets, m_frames, m_rev_offsets, m_rev_pairs, m_pair_samples, m_sample_materials;
  DeviceBuffer<R> m_weights, m_gradients, m_rest_offsets, m_volumes, m_sample_rest, m_frame_rest, m_masses, m_inertias;
  DeviceBuffer<Material> m_materials;
  DeviceBuffer<unsigned char> m_fixed;
  DeviceBuffer<int> m_block_samples, m_block_slots, m_slot_frames, m_slot_pair_offsets, m_slot_pairs,
      m_frame_slot_offsets, m_frame_slots, m_ell_offsets, m_slot_ell, m_ell_frame;
  DeviceBuffer<unsigned short> m_ell_slot, m_ell_pos, m_ell_slot_rank;
  DeviceBuffer<R> m_ell_data, m_pair_records, m_sample_records, m_records, m_levers, m_sample_state;
  DeviceBuffer<int> m_shape_class, m_class_offsets;
  DeviceBuffer<R> m_shape_maps, m_class_pairs;
  // Grouped pass (upload_groups).
  int m_group_blocks = 0, m_group_count = 0;
  DeviceBuffer<int> m_group_samples, m_group_frames, m_group_block_slots, m_group_slot_pair_offsets,
      m_group_frame_slot_offsets, m_group_slot_store;
  DeviceBuffer<unsigned short> m_group_pos;
  DeviceBuffer<R> m_group_data, m_group_partials;
  DeviceBuffer<int> m_group_class;
  DeviceBuffer<R> m_group_maps, m_group_class_pairs;
  // State (double) and per-iteration data (R).
  DeviceBuffer<double> m_positions, m_orientations, m_velocities, m_external, m_load_rot, m_diag;
  DeviceBuffer<double> m_prepare_sums;  // k_frame_columns -> k_frame_finish: [N][kPrepareSums]
  DeviceBuffer<R> m_x, m_rot, m_F, m_cache, m_a, m_partials, m_geo, m_inertia_world, m_minv;
  DeviceBuffer<R> m_step_block;  // [N][9] the PCG's rotational frame block (frame_block)
  DeviceBuffer<R> m_grad, m_d, m_out, m_cx, m_cr, m_cz, m_cp, m_cAp;
  // Reductions.
  DeviceBuffer<double> m_red_partials;
  DeviceBuffer<unsigned> m_counter;
  DeviceBuffer<Scalars> m_scalars;
};

}  // namespace

// ---- public classes ------------------------------------------------------------------------------

DeviceElasticity::DeviceElasticity(const Model& model, const DeviceOptions& options) {
  if (options.block_samples < 32 || options.block_samples % 32 != 0 || options.block_samples > 1024)
    throw std::invalid_argument("DeviceOptions: block_samples must be a multiple of 32 in [32, 1024]");
  if (options.lane_threads < 32 || options.lane_threads % 32 != 0 || options.lane_threads > kLaneThreadsMax)
    throw std::invalid_argument("DeviceOptions: lane_threads must be a multiple of 32 in [32, 512]");
  if (options.row_frames < 1 || 6 * options.row_frames > kLaneThreadsMax)
    throw std::invalid_argument("DeviceOptions: row_frames must be in [1, 85]");
  if (options.record_keep < 1 || options.record_keep > 2)
    throw std::invalid_argument("DeviceOptions: record_keep must be 1 or 2");
  if (options.coalesced_keep != 0 && options.coalesced_keep != 2 && options.coalesced_keep != 4 &&
      options.coalesced_keep != 8)
    throw std::invalid_argument("DeviceOptions: coalesced_keep must be 0, 2, 4 or 8");
  if (options.slot_lanes < 1 || options.slot_lanes > 32 || (options.slot_lanes & (options.slot_lanes - 1)) != 0)
    throw std::invalid_argument("DeviceOptions: slot_lanes must be a power of two in [1, 32]");
  if (options.precision == Precision::double_precision)
    m_impl = std::make_unique<System<double>>(model, options);
  else
    m_impl = std::make_unique<System<float>>(model, options);
}
DeviceElasticity::~DeviceElasticity() = default;

void DeviceElasticity::set_state(const State& state) { m_impl->set_state(state); }
void DeviceElasticity::get_state(State& state) const { m_impl->get_state(state); }
double DeviceElasticity::energy() { return m_impl->energy(); }
double DeviceElasticity::gradient(double* g) { return m_impl->gradient(g); }
double DeviceElasticity::prepare() { return m_impl->prepare(); }
void DeviceElasticity::apply_tangent(const double* d, double* out) { m_impl->apply_tangent(d, out); }
void DeviceElasticity::tangent_diagonal_blocks(double* blocks) { m_impl->diagonal_blocks(blocks); }
Design DeviceElasticity::design() const { return m_impl->design; }
SamplePass DeviceElasticity::sample_pass() const { return m_impl->pass; }
int DeviceElasticity::lanes() const { return m_impl->lanes; }
bool DeviceElasticity::dense_tangent() const { return m_impl->dense; }
const std::string& DeviceElasticity::shape_classes_refusal() const { return m_impl->mapped_refusal; }
bool DeviceElasticity::slot_frames() const { return m_impl->slot_frames; }
bool DeviceElasticity::direction_pass() const { return m_impl->direction_pass; }
bool DeviceElasticity::hold_pairs() const { return m_impl->hold_pairs; }
bool DeviceElasticity::prefetch_frames() const { return m_impl->prefetch_frames; }
bool DeviceElasticity::resident_frames() const { return m_impl->resident_frames(); }
bool DeviceElasticity::shape_classes() const { return m_impl->mapped; }
bool DeviceElasticity::group_samples() const { return m_impl->grouped; }
const std::string& DeviceElasticity::group_samples_refusal() const { return m_impl->grouped_refusal; }
bool DeviceElasticity::group_classes() const { return m_impl->group_mapped; }
const std::string& DeviceElasticity::group_classes_refusal() const { return m_impl->group_classes_refusal; }
Precision DeviceElasticity::precision() const { return m_impl->options.precision; }
const DeviceOptions& DeviceElasticity::options() const { return m_impl->options; }
double DeviceElasticity::time_tangent_ms(int repeats) { return m_impl->time_tangent_ms(std::max(1, repeats)); }
double DeviceElasticity::tangent_bytes() const { return m_impl->tangent_bytes(); }
KernelResources DeviceElasticity::tangent_kernel_resources() const { return m_impl->tangent_kernel_resources(); }
LaunchGrids DeviceElasticity::launch_grids() const { return m_impl->launch_grids(); }

struct DeviceBackwardEuler::Impl {
  DeviceElasticity::Impl* system;
};

DeviceBackwardEuler::DeviceBackwardEuler(DeviceElasticity& elasticity, const StepOptions& options)
    : m_impl(std::make_unique<Impl>(Impl{elasticity.m_impl.get()})) {
  m_impl->system->configure_step(options);
}
DeviceBackwardEuler::~DeviceBackwardEuler() = default;
StepReport DeviceBackwardEuler::step() { return m_impl->system->step(); }
void DeviceBackwardEuler::last_increment(double* delta) const { m_impl->system->last_increment(delta); }
double DeviceBackwardEuler::time_step_ms(int repeats) { return m_impl->system->time_step_ms(std::max(1, repeats)); }
double DeviceBackwardEuler::time_cg_iteration_ms(int repeats) {
  return m_impl->system->time_cg_iteration_ms(std::max(1, repeats));
}

}  // namespace fascia::gpu
