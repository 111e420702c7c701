#include "device_buffers.cuh"
#include "device_elasticity.hpp"
#include "device_vector.cuh"
#include "elasticity_kernels.cuh"
#include "group_kernels.cuh"
#include "group_layout.hpp"
#include "sample_layout.hpp"
#include "tangent_terms.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <numeric>

namespace fascia::gpu {

const char* to_string(Precision precision) {
  return precision == Precision::double_precision ? "double" : "single";
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

void create_context() {
  cudaFree(nullptr);
  cudaGetLastError();
}

namespace {

constexpr int kThreads = 128;  // the per-frame and per-sample kernels
// Samples per block of the force and tangent passes: one thread each, the block size the dense
// tangent kernels are compiled for (kDenseThreads).
constexpr int kBlockSamples = 128;
// Pairs and distinct frames per block at most: they bound the shared memory of a block's pair
// outputs.
constexpr int kMaxBlockPairs = 1024;
constexpr int kMaxBlockSlots = 256;
// Lanes that sum one slot of a block's pair outputs in the launched tangent kernels (a power of
// two <= 32): two halve the chain of dependent adds of one lane and keep the stores coalesced.
constexpr int kSlotLanes = 2;
// Threads per sample of the launched coalesced tangent kernel (ell_tangent_block's Lanes) for
// models whose samples have more than kLanedPairs neighbour frames on average: a sample's pairs
// are a chain of dependent loads, which four lanes shorten fourfold (meshless samples have 12 or
// more; mesh samples 4 or 8, which one thread takes). Such models' blocks hold
// kBlockSamples / kSampleLanes samples, one pass of the block's threads.
constexpr int kLanedPairs = 8;
constexpr int kSampleLanes = 4;
// Threads per frame of the frame pass (k_frame_sums' Lanes) for models whose frames have more than
// kLanedSlots slot partials on average (meshless: tens, a frame in the blocks of every sample
// around it), where one thread per frame leaves the device nearly idle on a chain of dependent
// loads; mesh models keep one thread per frame. A warp per frame: at 56 k samples the pelvis's
// 1,827 frames then fill the device four times as much as with eight lanes (ncu on an H200: 12 µs
// a pass against 26).
constexpr int kLanedSlots = 8;
constexpr int kFrameLanes = 32;
int grid_for(long long count, int threads) { return static_cast<int>(std::max<long long>(1, (count + threads - 1) / threads)); }

// The frames' state [N][3] positions x and [N][4] orientations q into y_x and y_q (one thread per
// value, the positions' 3N first), *changed = 1 where a value's bits differ (every writer writes 1).
__global__ void k_take_state(long long frames, const double* x, const double* q, double* y_x, double* y_q,
                             int* changed) {
  const long long i = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x;
  if (i >= 7 * frames) return;
  const double* from = i < 3 * frames ? x + i : q + (i - 3 * frames);
  double* to = i < 3 * frames ? y_x + i : y_q + (i - 3 * frames);
  if (__double_as_longlong(*from) == __double_as_longlong(*to)) return;
  *to = *from;
  *changed = 1;
}

}  // namespace

// The implementation of DeviceElasticity: abstract over the storage precision.
struct DeviceElasticity::Impl {
  virtual ~Impl() = default;
  virtual void set_state(const State& state) = 0;
  virtual void get_state(State& state) const = 0;
  virtual double energy() = 0;
  virtual double gradient(double* g) = 0;
  virtual double prepare(bool diagonal_blocks) = 0;
  virtual void prepare_on_device(bool diagonal_blocks) = 0;
  virtual void apply_tangent(const double* d, double* out) = 0;
  virtual void diagonal_blocks(double* blocks) = 0;
  virtual void* stream() const = 0;
  virtual void set_state_on_device(const double* positions, const double* orientations) = 0;
  // The state on the device: positions [N][3], orientations [N][4].
  virtual const double* positions_on_device() const = 0;
  virtual const double* orientations_on_device() const = 0;
  virtual void gradient_on_device(double* g) = 0;
  virtual const double* energy_on_device() const = 0;
  virtual void apply_tangent_on_device(const double* d, double* out, const double* frame_diagonal) = 0;
  virtual void set_tangent_blocks(const std::vector<int>& block_offsets, const std::vector<int>& block_frames,
                                  const std::vector<int>& diagonal_blocks) = 0;
  virtual void tangent_blocks_on_device(double* blocks) = 0;
  virtual const double* diagonal_blocks_on_device() const = 0;
  virtual double time_tangent_ms(int repeats) = 0;
  virtual double tangent_bytes() const = 0;
  virtual KernelResources tangent_kernel_resources() const = 0;
  virtual LaunchGrids launch_grids() const = 0;
  virtual void limit_row_blocks(int blocks) = 0;

  DeviceOptions options;
  bool grouped = false;         // the launched tangent product runs the grouped pass
  std::string grouped_refusal;  // why not
};

namespace {

template <class R>
class System final : public DeviceElasticity::Impl {
 public:
  System(const Model& input, const DeviceOptions& opts, cudaStream_t shared) {
    options = opts;
    validate(input);
    if (!offsets_are_rest_differences(input))
      throw std::invalid_argument(
          "DeviceElasticity: the model's rest offsets are not p_s - x_i (eq. 2 with rest orientation I)");
    m_own_stream = shared == nullptr;
    if (m_own_stream)
      FASCIA_CUDA(cudaStreamCreateWithFlags(&m_stream, cudaStreamNonBlocking));
    else
      m_stream = shared;
    FASCIA_CUDA(cudaEventCreate(&m_start));
    FASCIA_CUDA(cudaEventCreate(&m_stop));
    // Samples in Morton order; in group order from it where the model allows the grouped pass,
    // which needs each group's samples consecutive. Models whose groups average fewer than
    // kMinGroupSamples samples are refused before they are put in group order.
    std::vector<int> order = spatial_sample_order(input);
    grouped_refusal = group_refusal(input);
    if (grouped_refusal.empty()) {
      double mean = 0;
      std::vector<int> grouped_order = group_sample_order(input, order, &mean);
      if (mean < kMinGroupSamples) {
        char text[160];
        std::snprintf(text, sizeof text,
                      "its groups of samples with the same frames average %.2f samples (at least %.0f needed)", mean,
                      kMinGroupSamples);
        grouped_refusal = text;
      } else {
        order = std::move(grouped_order);
      }
    }
    const Model model = reorder_samples(input, order);
    m_n = model.frame_count();
    m_s = model.sample_count();
    m_p = model.pair_count();
    m_max_neighbours = model.max_neighbours();
    m_fibres = std::any_of(model.materials.begin(), model.materials.end(),
                           [](const Material& mat) { return mat.law == MaterialLaw::hgo; });

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
    m_rev_offsets.upload(model.reverse.offsets);
    m_rev_pairs.upload(model.reverse.pairs);
    m_pair_samples.upload(model.reverse.pair_samples);
    m_volumes.upload(model.samples.volumes);
    m_sample_materials.upload(model.samples.materials);
    m_materials.upload(model.materials);
    m_sample_rest.upload(sample_rest);
    m_frame_rest.upload(frame_rest);

    m_lanes = model.pair_count() > static_cast<long long>(kLanedPairs) * model.sample_count() ? kSampleLanes : 1;
    BlockLayout L = build_block_layout(model, kBlockSamples / m_lanes, kMaxBlockPairs, kMaxBlockSlots);
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
    // ELL entries held in registers per lane (more are read again): 2 in double, where 4 spills,
    // and where samples have at most 2 pairs; else 4 in single.
    m_keep = m_max_neighbours <= 2 || std::is_same_v<R, double> ? 2 : 4;
    upload_coalesced(model, L);
    if (grouped_refusal.empty()) {
      upload_groups(model);
      grouped = true;
    }
    FASCIA_CUDA(cudaFuncSetAttribute(force_kernel(), cudaFuncAttributeMaxDynamicSharedMemorySize,
                                     static_cast<int>(m_shared_bytes)));

    m_view.samples = m_s;
    m_view.frames = m_n;
    m_view.pairs = m_p;
    m_view.offsets = m_offsets.data();
    m_view.frame_of = m_frames.data();
    m_view.weights = m_weights.data();
    m_view.gradients = m_gradients.data();
    m_view.rev_offsets = m_rev_offsets.data();
    m_view.rev_pairs = m_rev_pairs.data();
    m_view.pair_samples = m_pair_samples.data();
    m_view.volumes = m_volumes.data();
    m_view.sample_materials = m_sample_materials.data();
    m_view.materials = m_materials.data();
    m_view.sample_rest = m_sample_rest.data();
    m_view.frame_rest = m_frame_rest.data();
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
    m_view.ell_frame = m_ell_frame.data();
    m_view.ell_pos = m_ell_pos.data();
    if (grouped) {
      m_group_view = m_view;
      m_group_view.blocks = m_group_blocks;
      m_group_view.block_samples = nullptr;  // block b's groups are [kGroupBlock b, ...) (group_layout.hpp)
      m_group_view.block_slots = m_group_block_slots.data();
      m_group_view.slot_frames = nullptr;  // neither the grouped kernel nor k_frame_sums reads them
      m_group_view.slot_pair_offsets = m_group_slot_pair_offsets.data();
      m_group_view.slot_pairs = nullptr;
      m_group_view.frame_slot_offsets = m_group_frame_slot_offsets.data();
      m_group_view.frame_slots = nullptr;  // the partials are stored frame-major (slot_store)
      m_group_view.slot_store = m_group_slot_store.data();
      m_group_view.group_count = m_group_count;
      m_group_view.group_samples = m_group_samples.data();
      m_group_view.group_frames = m_group_frames.data();
      m_group_view.group_pos = m_group_pos.data();
      m_group_view.group_data = m_group_data.data();
      m_group_view.group_entries = static_cast<long long>(m_group_data.size() / 4);
    }

    const size_t dofs = 6 * static_cast<size_t>(m_n);
    m_positions.resize(3 * static_cast<size_t>(m_n));
    m_orientations.resize(4 * static_cast<size_t>(m_n));
    m_x.resize(3 * static_cast<size_t>(m_n));
    m_rot.resize(9 * static_cast<size_t>(m_n));
    m_F.resize(9 * static_cast<size_t>(m_s));
    m_P.resize(9 * static_cast<size_t>(m_s));
    m_geo.resize(9 * static_cast<size_t>(m_n));
    m_diag.resize(36 * static_cast<size_t>(m_n));
    m_prepare_sums.resize(kPrepareSums * static_cast<size_t>(m_n));
    m_d.resize(dofs);
    m_grad.resize(dofs);
    m_out.resize(dofs);
    // The partials and counters of the force pass's reduction (reduce_and_finish).
    const int max_grid = std::max(m_blocks, 1);
    m_red_partials.resize(reduce_partial_count(max_grid));
    m_counter.resize(reduce_counter_count(max_grid));
    m_counter.zero();
    m_scalars.resize(1);
    m_scalars.zero();
    m_changed.resize(1);
    mark_changed();
    // The launched frame pass loops over its frames in the blocks that fit at once.
    m_frame_lanes = !grouped && m_slots > static_cast<long long>(kLanedSlots) * m_n ? kFrameLanes : 1;
    m_rows_grid = resident_blocks(frame_sums_kernel(m_frame_lanes), kFrameThreads,
                                  grid_for(static_cast<long long>(m_frame_lanes) * m_n, kFrameThreads));
    m_frame_view.rotations = m_rot.data();
    m_frame_view.positions = m_x.data();
    m_frame_view.levers = m_levers.data();
    m_frame_view.sample_state = m_sample_state.data();
  }

  ~System() override {
    cudaEventDestroy(m_start);
    cudaEventDestroy(m_stop);
    if (m_own_stream) cudaStreamDestroy(m_stream);
  }

  void set_state(const State& state) override {
    if (state.frame_count() != m_n) throw std::invalid_argument("DeviceElasticity: state has the wrong frame count");
    m_positions.upload(state.positions, m_stream);
    m_orientations.upload(state.orientations, m_stream);
    mark_changed();
  }

  // The next preparation takes a force pass (the state came from the host).
  void mark_changed() {
    const int changed = 1;
    m_changed.upload(&changed, 1, m_stream);
  }

  void get_state(State& state) const override {
    state.positions.resize(3 * static_cast<size_t>(m_n));
    state.orientations.resize(4 * static_cast<size_t>(m_n));
    FASCIA_CUDA(cudaStreamSynchronize(m_stream));
    m_positions.download(state.positions.data());
    m_orientations.download(state.orientations.data());
  }

  double energy() override {
    enqueue_gradient_pass(nullptr);
    return read_scalars().energy;
  }

  double gradient(double* g) override {
    enqueue_gradient_pass(m_grad.data());
    const double e = read_scalars().energy;
    m_grad.download(g);
    return e;
  }

  double prepare(bool diagonal_blocks) override {
    prepare_on_device(diagonal_blocks);
    return read_scalars().energy;
  }

  // The force pass is skipped where the state is the last pass's (Newton prepares the state whose
  // gradient its line search has just taken): F, the cache and the samples' state are its.
  void prepare_on_device(bool diagonal_blocks) override {
    enqueue_gradient_pass(nullptr, true);
    enqueue_frame_prepare(diagonal_blocks);
  }

  void apply_tangent(const double* d, double* out) override {
    m_d.upload(d, 6 * static_cast<size_t>(m_n), m_stream);
    enqueue_tangent(m_d.data(), m_out.data(), nullptr);
    FASCIA_CUDA(cudaStreamSynchronize(m_stream));
    m_out.download(out);
  }

  void diagonal_blocks(double* blocks) override {
    FASCIA_CUDA(cudaStreamSynchronize(m_stream));
    m_diag.download(blocks);
  }

  void* stream() const override { return m_stream; }

  void set_state_on_device(const double* positions, const double* orientations) override {
    k_take_state<<<grid_for(7LL * m_n, kThreads), kThreads, 0, m_stream>>>(
        m_n, positions, orientations, m_positions.data(), m_orientations.data(), m_changed.data());
    check_launch();
  }

  const double* positions_on_device() const override { return m_positions.data(); }
  const double* orientations_on_device() const override { return m_orientations.data(); }

  // An energy alone (g null) at the last pass's state is that pass's: its force pass is skipped (a
  // step's reported energy, at the state whose gradient Newton took last). A gradient is always
  // formed anew: the tangent products overwrite the slot partials it is summed from.
  void gradient_on_device(double* g) override { enqueue_gradient_pass(g, g == nullptr); }

  const double* energy_on_device() const override { return &m_scalars.data()->energy; }

  void apply_tangent_on_device(const double* d, double* out, const double* frame_diagonal) override {
    if constexpr (std::is_same_v<R, double>) {
      enqueue_tangent(d, out, frame_diagonal);  // the passes read d and write every row of out
    } else {
      convert_async(d, m_d.data(), 6LL * m_n, m_stream);
      enqueue_tangent(m_d.data(), out, frame_diagonal);
    }
  }

  const double* diagonal_blocks_on_device() const override { return m_diag.data(); }

  void tangent_blocks_on_device(double* blocks) override {
    if (m_block_count == 0) return;
    k_pair_columns<R><<<grid_for(m_p, kThreads), kThreads, 0, m_stream>>>(m_view, m_frame_view, m_pair_columns.data());
    check_launch();
    k_tangent_blocks<R><<<grid_for(32LL * m_block_count, kTangentBlockThreads), kTangentBlockThreads, 0, m_stream>>>(
        m_view, m_frame_view, m_block_count, m_contribution_offsets.data(), m_contributions.data(),
        m_pair_columns.data(), blocks);
    check_launch();
    k_add_rotational_geometric<R><<<grid_for(m_n, kThreads), kThreads, 0, m_stream>>>(
        m_n, m_diagonal_blocks.data(), m_geo.data(), blocks);
    check_launch();
  }

  // Each block's terms, the pairs (p_a, p_b) of the samples of frames a and b, in the order of
  // frame a's pairs (the reverse table: increasing sample); none for the blocks with b > a, the
  // transposes of (b, a), which are written as zero (device_elasticity.hpp).
  void set_tangent_blocks(const std::vector<int>& block_offsets, const std::vector<int>& block_frames,
                          const std::vector<int>& diagonal_blocks) override {
    m_diagonal_blocks.upload(diagonal_blocks);
    NeighbourTable nb;
    ReverseTable rev;
    nb.offsets.resize(m_offsets.size());
    nb.frames.resize(m_frames.size());
    rev.offsets.resize(m_rev_offsets.size());
    rev.pairs.resize(m_rev_pairs.size());
    rev.pair_samples.resize(m_pair_samples.size());
    m_offsets.download(nb.offsets.data());
    m_frames.download(nb.frames.data());
    m_rev_offsets.download(rev.offsets.data());
    m_rev_pairs.download(rev.pairs.data());
    m_pair_samples.download(rev.pair_samples.data());
    m_block_count = static_cast<int>(block_frames.size());
    const TangentTerms terms = tangent_terms(nb, rev, block_offsets, block_frames);
    m_contribution_offsets.upload(terms.offsets);
    m_contributions.upload(terms.pairs);
    m_pair_columns.resize(static_cast<size_t>(kPairColumns) * static_cast<size_t>(m_p));
  }

  double time_tangent_ms(int repeats) override {
    std::vector<double> d(6 * static_cast<size_t>(m_n));
    for (size_t k = 0; k < d.size(); ++k) d[k] = 1e-3 * std::sin(0.37 * static_cast<double>(k));
    m_d.upload(d);
    for (int k = 0; k < 3; ++k) enqueue_tangent(m_d.data(), m_out.data(), nullptr);
    FASCIA_CUDA(cudaEventRecord(m_start, m_stream));
    for (int k = 0; k < repeats; ++k) enqueue_tangent(m_d.data(), m_out.data(), nullptr);
    FASCIA_CUDA(cudaEventRecord(m_stop, m_stream));
    FASCIA_CUDA(cudaEventSynchronize(m_stop));
    float ms = 0;
    FASCIA_CUDA(cudaEventElapsedTime(&ms, m_start, m_stop));
    return ms / repeats;
  }

  double tangent_bytes() const override {
    const double r = sizeof(R), P = m_p, S = m_s, N = m_n;
    // Frames: rotation, position, d (read), out (write, double), geometric block (read).
    const double frames = N * (9 * r + 3 * r + 6 * r + 6 * 8.0 + 9 * r);
    if (grouped) {
      // Per pair w and g; per group its frames, entry positions and first sample; per sample its
      // state (StVK: 13 values), material and offset; lever records (instead of rotation and
      // position), read once per group but counted once; the slot tables of the blocks of groups
      // and their slot partials out and in.
      const double Q = static_cast<double>(m_group_partials.size()) / 6, G = m_group_count;
      return P * 4 * r + G * (kGroupLanes * 6 + 4) + S * (13 * r + 4 + 4) + N * (kLeverRecord * r - 12 * r) + Q * 4 +
             N * 4 + m_group_blocks * 8 + Q * 6 * r * 2 + frames;
    }
    // ELL entries (frame, w, g), per-sample state and offsets and materials, lever records
    // (instead of rotation and position), slot tables, slot partials out and in.
    // StVK reads 13 state values per sample (elasticity_phases.hpp, kSampleState).
    const double Q = m_slots, E = m_ell_entries;
    return E * (4 * r + 4 + 2) + S * (13 * r + 4 + 4) + N * (kLeverRecord * r - 12 * r) + Q * 4 + N * 4 +
           m_blocks * 12 + Q * 6 * r * 2 + frames;
  }

  // The coalesced tangent pass's tables (build_ell_order, the entries' frames), the storage of
  // lever records and samples' state, and its shared-memory size (6 values per ELL entry of the
  // largest block).
  void upload_coalesced(const Model& model, BlockLayout& L) {
    build_ell_order(model, L);
    const size_t pairs = static_cast<size_t>(L.max_block_pairs);
    int shared_limit = 0, dev = 0;
    FASCIA_CUDA(cudaGetDevice(&dev));
    FASCIA_CUDA(cudaDeviceGetAttribute(&shared_limit, cudaDevAttrMaxSharedMemoryPerBlockOptin, dev));
    // A block holds more than kMaxBlockPairs pairs only where one sample has that many.
    if (6 * pairs * sizeof(R) > static_cast<size_t>(shared_limit))
      throw std::invalid_argument("DeviceElasticity: a sample has " + std::to_string(pairs) +
                                  " neighbour frames, more than a thread block's shared memory holds (" +
                                  std::to_string(shared_limit / (6 * sizeof(R))) + ")");
    m_ell_bytes = 6 * pairs * sizeof(R);
    upload_ell(model, L);
    m_ell_pos.upload(std::vector<unsigned short>(L.ell_pos.begin(), L.ell_pos.end()));
    m_levers.resize(kLeverRecord * static_cast<size_t>(m_n));
    m_sample_state.resize(kSampleState * static_cast<size_t>(m_s));
    FASCIA_CUDA(cudaFuncSetAttribute(reinterpret_cast<const void*>(ell_tangent_kernel(m_keep, m_lanes)),
                                     cudaFuncAttributeMaxDynamicSharedMemorySize, static_cast<int>(m_ell_bytes)));
  }

  // The grouped pass's tables (group_layout.hpp) for a model in group order whose groups average
  // kMinGroupSamples samples at least (the constructor refuses others): groups, their frames and
  // entry positions, w and g per (block, frame, thread), the slot tables of its blocks.
  void upload_groups(const Model& model) {
    const GroupLayout G = build_group_layout(model);
    const BlockLayout& L = G.slots;
    m_group_blocks = L.block_count();
    m_group_count = G.group_count();
    upload_group_data(model, G);
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

  // The ELL tables of a layout with build_ell_order's order: entry offsets, slots, w and g
  // ([4][E]) and each entry's frame.
  void upload_ell(const Model& model, const BlockLayout& L) {
    const NeighbourTable& nb = model.neighbours;
    const int E = L.ell_count();
    std::vector<double> ell(4 * static_cast<size_t>(E), 0.0);  // [4][E]: w, g
    std::vector<int> ell_frame(E, 0);
    for (int p = 0; p < model.pair_count(); ++p) {
      const int e = L.pair_ell[p];
      ell[e] = nb.weights[p];
      for (int k = 0; k < 3; ++k) ell[static_cast<size_t>(k + 1) * E + e] = nb.weight_gradients[3 * p + k];
      ell_frame[e] = nb.frames[p];
    }
    m_ell_offsets.upload(L.ell_offsets);
    m_ell_slot.upload(std::vector<unsigned short>(L.ell_slot.begin(), L.ell_slot.end()));
    m_ell_data.upload(ell);
    m_ell_frame.upload(ell_frame);
    m_ell_entries = E;
  }

  LaunchGrids launch_grids() const override {
    return LaunchGrids{grid_for(m_n, kFrameThreads), m_rows_grid, kReduceChunk};
  }

  void limit_row_blocks(int blocks) override {
    if (blocks < 1) throw std::invalid_argument("DeviceElasticity::limit_row_blocks: blocks must be >= 1");
    m_rows_grid = std::min(m_rows_grid, blocks);
  }

  KernelResources tangent_kernel_resources() const override {
    cudaFuncAttributes attr{};
    FASCIA_CUDA(cudaFuncGetAttributes(&attr, tangent_sample_kernel()));
    return KernelResources{attr.numRegs, static_cast<long long>(attr.localSizeBytes)};
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

  // Kinematics and the force pass: energy into the scalars, F, the material cache and the samples'
  // state of the tangent product stored, the gradient [N][6] into `gradient` (device memory) where
  // it is set; with `if_changed`, the force pass only where the state differs from the last
  // pass's (decided on the device).
  void enqueue_gradient_pass(double* gradient, bool if_changed = false) {
    k_kinematics<R><<<grid_for(m_n, kThreads), kThreads, 0, m_stream>>>(
        m_n, m_positions.data(), m_orientations.data(), m_origin, m_x.data(), m_rot.data(), m_frame_rest.data(),
        m_levers.data());
    check_launch();
    force_kernel()<<<m_blocks, kBlockSamples, m_shared_bytes, m_stream>>>(
        m_view, m_frame_view, m_F.data(), m_cache.data(), m_P.data(), m_partials.data(), reduction(),
        m_sample_state.data(), if_changed ? m_changed.data() : nullptr);
    check_launch();
    FASCIA_CUDA(cudaMemsetAsync(m_changed.data(), 0, sizeof(int), m_stream));
    if (gradient) enqueue_frame_rows(m_view, m_partials.data(), nullptr, nullptr, nullptr, gradient);
  }

  // The per-frame preparation: the rotational geometric blocks Kr (m_geo) and, with `diag`, the
  // diagonal blocks K_ii (m_diag).
  void enqueue_frame_prepare(bool diag) {
    const dim3 grid = grid_for(m_n, kColumnFrames);
    if (!diag) {
      k_frame_columns<R, false><<<grid, kColumnParts * kColumnFrames, 0, m_stream>>>(
          m_view, m_frame_view, m_F.data(), m_P.data(), nullptr, m_geo.data());
      check_launch();
      return;
    }
    k_frame_columns<R, true><<<grid, kColumnParts * kColumnFrames, 0, m_stream>>>(
        m_view, m_frame_view, m_F.data(), nullptr, m_prepare_sums.data(), nullptr);
    check_launch();
    k_frame_finish<R><<<grid_for(m_n, kThreads), kThreads, 0, m_stream>>>(m_n, m_prepare_sums.data(), m_geo.data(),
                                                                        m_diag.data());
    check_launch();
  }

  // The frame pass of the launched tangent product (k_frame_sums): out = K d (+ D d) from the slot
  // partials, the rotational geometric blocks geo and the frame terms D (the force pass's gather:
  // d, geo and D null).
  void enqueue_frame_rows(const ModelView<R>& view, const R* partials, const R* geo, const R* d,
                          const double* frame_diagonal, double* out) {
    const auto kernel = m_frame_lanes == 1 ? &k_frame_sums<R, 1> : &k_frame_sums<R, kFrameLanes>;
    kernel<<<m_rows_grid, kFrameThreads, 0, m_stream>>>(view, partials, geo, d, frame_diagonal, out);
    check_launch();
  }

  // The launched tangent product's sample kernel in use (enqueue_tangent's choice).
  const void* tangent_sample_kernel() const {
    if (grouped) return m_fibres ? reinterpret_cast<const void*>(&k_group_tangent<R, true>)
                                 : reinterpret_cast<const void*>(&k_group_tangent<R, false>);
    return reinterpret_cast<const void*>(ell_tangent_kernel(m_keep, m_lanes));
  }

  // out = K d (+ D d with frame_diagonal): the grouped or the coalesced sample pass, then the
  // frame pass.
  void enqueue_tangent(const R* d, double* out, const double* frame_diagonal) {
    if (grouped) {
      const auto kernel = m_fibres ? &k_group_tangent<R, true> : &k_group_tangent<R, false>;
      kernel<<<m_group_blocks, kGroupThreads, 0, m_stream>>>(m_group_view, m_frame_view, d, m_group_partials.data(),
                                                             kSlotLanes);
      check_launch();
      enqueue_frame_rows(m_group_view, m_group_partials.data(), m_geo.data(), d, frame_diagonal, out);
      return;
    }
    ell_tangent_kernel(m_keep, m_lanes)<<<m_blocks, kDenseThreads, m_ell_bytes, m_stream>>>(
        m_view, m_frame_view, d, m_partials.data(), kSlotLanes);
    check_launch();
    enqueue_frame_rows(m_view, m_partials.data(), m_geo.data(), d, frame_diagonal, out);
  }

  // The force pass's kernel, with the tangent pass's threads per sample (its blocks' samples).
  using ForceKernel = void (*)(ModelView<R>, FrameView<R>, R*, R*, R*, R*, Reduction, R*, const int*);
  ForceKernel force_kernel() const { return m_lanes == 1 ? &k_fused_samples<R, 1> : &k_fused_samples<R, kSampleLanes>; }

  // The launched coalesced tangent kernel for `keep` held ELL entries per lane (2, else 4; double
  // holds 2) and `lanes` threads per sample (1, else kSampleLanes).
  using EllTangentKernel = void (*)(ModelView<R>, FrameView<R>, const R*, R*, int);
  static const void* frame_sums_kernel(int lanes) {
    return lanes == 1 ? reinterpret_cast<const void*>(&k_frame_sums<R, 1>)
                      : reinterpret_cast<const void*>(&k_frame_sums<R, kFrameLanes>);
  }
  static EllTangentKernel ell_tangent_kernel(int keep, int lanes) {
    if constexpr (!std::is_same_v<R, double>)
      if (keep == 4) return lanes == 1 ? &k_ell_tangent<R, 4, 1> : &k_ell_tangent<R, 4, kSampleLanes>;
    return lanes == 1 ? &k_ell_tangent<R, 2, 1> : &k_ell_tangent<R, 2, kSampleLanes>;
  }

  // Blocks of `kernel` (`threads` each) that fit on the device at once, at most `blocks`.
  static int resident_blocks(const void* kernel, int threads, int blocks) {
    int dev = 0, sms = 0, per_sm = 0;
    FASCIA_CUDA(cudaGetDevice(&dev));
    FASCIA_CUDA(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, dev));
    FASCIA_CUDA(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, kernel, threads, 0));
    return std::max(1, std::min(blocks, std::max(1, per_sm) * sms));
  }

  // Grid of the launched frame pass (k_frame_sums): the blocks that fit at once (resident_blocks).
  int m_rows_grid = 1;
  int m_n = 0, m_s = 0, m_p = 0, m_blocks = 0, m_slots = 0;
  int m_ell_entries = 0, m_keep = 2, m_max_neighbours = 0;
  int m_lanes = 1;        // threads per sample of the launched coalesced tangent kernel
  int m_frame_lanes = 1;  // threads per frame of its frame pass
  bool m_fibres = false;  // some material is hgo: the grouped pass with its fibre code
  size_t m_shared_bytes = 0, m_ell_bytes = 0;
  Origin m_origin{};
  cudaStream_t m_stream = nullptr;
  bool m_own_stream = true;  // created here (else another object's stream, shared)
  cudaEvent_t m_start = nullptr, m_stop = nullptr;
  ModelView<R> m_view;
  ModelView<R> m_group_view;  // the grouped pass's: m_view with its blocks of groups and their slots
  FrameView<R> m_frame_view;

  // Model.
  DeviceBuffer<int> m_offsets, m_frames, m_rev_offsets, m_rev_pairs, m_pair_samples, m_sample_materials;
  // The tangent blocks' pattern and each block's pairs (tangent_blocks_on_device).
  int m_block_count = 0;
  DeviceBuffer<int> m_contribution_offsets, m_contributions;
  DeviceBuffer<int> m_diagonal_blocks;  // [N] each frame's block (a, a), -1: none
  DeviceBuffer<double> m_pair_columns;  // k_pair_columns: [P][kPairColumns]
  DeviceBuffer<R> m_weights, m_gradients, m_volumes, m_sample_rest, m_frame_rest;
  DeviceBuffer<Material> m_materials;
  DeviceBuffer<int> m_block_samples, m_block_slots, m_slot_frames, m_slot_pair_offsets, m_slot_pairs,
      m_frame_slot_offsets, m_frame_slots, m_ell_offsets, m_ell_frame;
  DeviceBuffer<unsigned short> m_ell_slot, m_ell_pos;
  DeviceBuffer<R> m_ell_data, m_levers, m_sample_state;
  // Grouped pass (upload_groups).
  int m_group_blocks = 0, m_group_count = 0;
  DeviceBuffer<int> m_group_samples, m_group_frames, m_group_block_slots, m_group_slot_pair_offsets,
      m_group_frame_slot_offsets, m_group_slot_store;
  DeviceBuffer<unsigned short> m_group_pos;
  DeviceBuffer<R> m_group_data, m_group_partials;
  // State (double) and per-iteration data (R).
  DeviceBuffer<double> m_positions, m_orientations, m_diag;
  DeviceBuffer<double> m_prepare_sums;  // k_frame_columns -> k_frame_finish: [N][kPrepareSums]
  DeviceBuffer<R> m_x, m_rot, m_F, m_cache, m_partials, m_geo;
  DeviceBuffer<R> m_P;  // the force pass's first Piola stress [S][9], for Kr without K_ii
  DeviceBuffer<R> m_d;
  DeviceBuffer<double> m_grad, m_out;
  // Reductions.
  DeviceBuffer<double> m_red_partials;
  DeviceBuffer<unsigned> m_counter;
  DeviceBuffer<int> m_changed;  // 1: the state differs from the last force pass's (set_state*)
  DeviceBuffer<Scalars> m_scalars;
};

}  // namespace

// ---- public classes ------------------------------------------------------------------------------

DeviceElasticity::DeviceElasticity(const Model& model, const DeviceOptions& options, void* stream) {
  const auto shared = static_cast<cudaStream_t>(stream);
  if (options.precision == Precision::double_precision) {
    m_impl = std::make_unique<System<double>>(model, options, shared);
  } else {
    m_impl = std::make_unique<System<float>>(model, options, shared);
    m_forces = std::make_unique<System<double>>(model, DeviceOptions{}, static_cast<cudaStream_t>(m_impl->stream()));
  }
}
DeviceElasticity::~DeviceElasticity() = default;

DeviceElasticity::Impl& DeviceElasticity::forces() const { return m_forces ? *m_forces : *m_impl; }

void DeviceElasticity::set_state(const State& state) { forces().set_state(state); }
void DeviceElasticity::get_state(State& state) const { forces().get_state(state); }
double DeviceElasticity::energy() { return forces().energy(); }
double DeviceElasticity::gradient(double* g) { return forces().gradient(g); }
double DeviceElasticity::prepare(bool diagonal_blocks) {
  // Single precision: the tangent's copy takes the state here, from the double copy, which every
  // state set reached (an energy or a gradient needs only that copy).
  if (m_forces) m_impl->set_state_on_device(m_forces->positions_on_device(), m_forces->orientations_on_device());
  return m_impl->prepare(diagonal_blocks);
}
void DeviceElasticity::prepare_on_device(bool diagonal_blocks) {
  if (m_forces) m_impl->set_state_on_device(m_forces->positions_on_device(), m_forces->orientations_on_device());
  m_impl->prepare_on_device(diagonal_blocks);
}
void DeviceElasticity::apply_tangent(const double* d, double* out) { m_impl->apply_tangent(d, out); }
void DeviceElasticity::tangent_diagonal_blocks(double* blocks) { m_impl->diagonal_blocks(blocks); }
void* DeviceElasticity::stream() const { return m_impl->stream(); }
void DeviceElasticity::set_state_on_device(const double* positions, const double* orientations) {
  forces().set_state_on_device(positions, orientations);
}
void DeviceElasticity::gradient_on_device(double* gradient) { forces().gradient_on_device(gradient); }
const double* DeviceElasticity::energy_on_device() const { return forces().energy_on_device(); }
void DeviceElasticity::apply_tangent_on_device(const double* d, double* out, const double* frame_diagonal) {
  m_impl->apply_tangent_on_device(d, out, frame_diagonal);
}
const double* DeviceElasticity::diagonal_blocks_on_device() const { return m_impl->diagonal_blocks_on_device(); }
void DeviceElasticity::set_tangent_blocks(const std::vector<int>& block_offsets, const std::vector<int>& block_frames,
                                          const std::vector<int>& diagonal_blocks) {
  m_impl->set_tangent_blocks(block_offsets, block_frames, diagonal_blocks);
}
void DeviceElasticity::tangent_blocks_on_device(double* blocks) { m_impl->tangent_blocks_on_device(blocks); }
bool DeviceElasticity::group_samples() const { return m_impl->grouped; }
const std::string& DeviceElasticity::group_samples_refusal() const { return m_impl->grouped_refusal; }
Precision DeviceElasticity::precision() const { return m_impl->options.precision; }
const DeviceOptions& DeviceElasticity::options() const { return m_impl->options; }
double DeviceElasticity::time_tangent_ms(int repeats) { return m_impl->time_tangent_ms(std::max(1, repeats)); }
double DeviceElasticity::tangent_bytes() const { return m_impl->tangent_bytes(); }
KernelResources DeviceElasticity::tangent_kernel_resources() const { return m_impl->tangent_kernel_resources(); }
LaunchGrids DeviceElasticity::launch_grids() const { return m_impl->launch_grids(); }
void DeviceElasticity::limit_row_blocks(int blocks) { m_impl->limit_row_blocks(blocks); }

}  // namespace fascia::gpu
