#include "device_sample_fields.hpp"

#include "device_buffers.cuh"
#include "io/sample_point.hpp"
#include "io/vertex_fields.hpp"

#include <algorithm>
#include <type_traits>

namespace fascia::gpu {
namespace {

constexpr int kThreads = 128;
constexpr int kMaxFields = 16;  // sample_fields.hpp lists 12

// Where field f's values lie in the device's output: [S][components[f]] from base[f].
struct FieldColumns {
  int components[kMaxFields];
  long long base[kMaxFields];
};

struct SampleInputs {
  SampleTableView table;
  int samples;
  const double* rest_positions;  // [S][3]
  const int* sample_materials;   // [S]
  const Material* materials;
  bool fibres;
};

__global__ void k_sample_fields(SampleInputs in, const double* x, const double* R, const double* velocities,
                                FieldColumns columns, double* out, double* positions) {
  const int s = blockIdx.x * blockDim.x + threadIdx.x;
  if (s >= in.samples) return;
  const Vec3 p = sample_point(in.table, s, x, R, velocities, load3(in.rest_positions + 3LL * s),
                              in.materials[in.sample_materials[s]], in.fibres, [&](int field, int c, double v) {
                                out[columns.base[field] + static_cast<long long>(columns.components[field]) * s + c] = v;
                              });
  store3(positions + 3LL * s, p);
}

constexpr int kMaxColumns = 48;  // the measure fields' components: 39, 40 with fibres

// The frame averages' columns: component c of measure field f reads the samples' values at
// in_base + in_stride s (the fields of k_sample_fields) and writes the frames' at
// out_base + out_stride i; `fibre`: the fibre stretch (its samples with fibres only).
struct AverageColumns {
  int count;
  long long in_base[kMaxColumns], out_base[kMaxColumns];
  int in_stride[kMaxColumns], out_stride[kMaxColumns];
  bool fibre[kMaxColumns];
};

// One warp per frame: the frame's average (frame_average.hpp's weights and pair shares) of every
// column where mask[i] (null: every frame) and its weight is positive, else 0. Lane l takes the
// frame's pairs l, l + 32, ... and sums every column's shares; an xor butterfly then adds the
// lanes' sums (the same order on every run).
__global__ void k_frame_averages(FrameAverageView v, int frames, const unsigned char* mask, AverageColumns columns,
                                 const double* samples, double* out) {
  const int i = static_cast<int>((blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x) / 32);
  const int lane = static_cast<int>(threadIdx.x % 32);
  if (i >= frames) return;  // the warp's lanes alike
  const bool on = !mask || mask[i];
  double weight = 0, weight_fibred = 0;
  if (on) frame_average_weights(v, i, lane, 32, weight, weight_fibred);
  for (int o = 16; o > 0; o >>= 1) {
    weight += __shfl_xor_sync(0xffffffffu, weight, o);
    weight_fibred += __shfl_xor_sync(0xffffffffu, weight_fibred, o);
  }
  double sum[kMaxColumns];
#pragma unroll
  for (int j = 0; j < kMaxColumns; ++j) sum[j] = 0;
  if (on && weight > 0)
    for (int k = v.offsets[i] + lane; k < v.offsets[i + 1]; k += 32) {
      const int q = v.pairs[k], s = v.pair_samples[q];
      const double share = pair_share(v, q, s, weight);
      const double fibre_share = weight_fibred > 0 && fibred(v, s) ? pair_share(v, q, s, weight_fibred) : 0.0;
#pragma unroll
      for (int j = 0; j < kMaxColumns; ++j)
        if (j < columns.count)
          sum[j] += (columns.fibre[j] ? fibre_share : share) *
                    samples[columns.in_base[j] + static_cast<long long>(columns.in_stride[j]) * s];
    }
#pragma unroll
  for (int j = 0; j < kMaxColumns; ++j) {
    if (j >= columns.count) break;
    double t = sum[j];
    for (int o = 16; o > 0; o >>= 1) t += __shfl_xor_sync(0xffffffffu, t, o);
    if (lane == j % 32) out[columns.out_base[j] + static_cast<long long>(columns.out_stride[j]) * i] = t;
  }
}

}  // namespace

static_assert(std::is_trivially_copyable_v<Material>, "materials are copied to the device as bytes");

struct DeviceSampleFields::Impl {
  const Model& model;
  cudaStream_t stream = nullptr;
  DeviceBuffer<int> offsets, frames, sample_materials;
  DeviceBuffer<double> weights, weight_gradients, rest_offsets, rest_positions, x, R, velocities, out, positions;
  DeviceBuffer<Material> materials;
  SampleInputs inputs{};
  // The frame averages: the reverse table, each material's fibres, the frames to average, the
  // output; and the columns of the last compute()'s fields.
  DeviceBuffer<int> rev_offsets, rev_pairs, pair_samples;
  DeviceBuffer<unsigned char> fibred_material, mask;
  DeviceBuffer<double> volumes, averages;
  FieldColumns columns{};
  size_t field_count = 0;
  // Pinned host memory the fields and positions come down to in one copy, at the bus's rate (a
  // copy to pageable memory goes through the driver's staging in pieces), then copied into the
  // fields: [fields' values..., positions].
  double* host = nullptr;
  size_t host_size = 0;

  explicit Impl(const Model& m) : model(m) {
    FASCIA_CUDA(cudaStreamCreateWithFlags(&stream, cudaStreamNonBlocking));
    const NeighbourTable& t = model.neighbours;
    offsets.upload(t.offsets);
    frames.upload(t.frames);
    weights.upload(t.weights);
    weight_gradients.upload(t.weight_gradients);
    rest_offsets.upload(t.rest_offsets);
    rest_positions.upload(model.samples.rest_positions);
    sample_materials.upload(model.samples.materials);
    materials.upload(model.materials);
    const int n = model.frame_count(), samples = model.sample_count();
    x.resize(3 * static_cast<size_t>(n));
    R.resize(9 * static_cast<size_t>(n));
    velocities.resize(6 * static_cast<size_t>(n));
    positions.resize(3 * static_cast<size_t>(samples));
    inputs = SampleInputs{{offsets.data(), frames.data(), weights.data(), weight_gradients.data(), rest_offsets.data()},
                          samples,
                          rest_positions.data(),
                          sample_materials.data(),
                          materials.data(),
                          has_fibres(model)};
    rev_offsets.upload(model.reverse.offsets);
    rev_pairs.upload(model.reverse.pairs);
    pair_samples.upload(model.reverse.pair_samples);
    fibred_material.upload(fibred_materials(model));
    volumes.upload(model.samples.volumes);
    mask.resize(static_cast<size_t>(n));
  }
  ~Impl() {
    if (host) cudaFreeHost(host);
    if (stream) cudaStreamDestroy(stream);
  }
  double* staging(size_t n) {
    if (n > host_size) {
      if (host) FASCIA_CUDA(cudaFreeHost(host));
      host = nullptr;
      FASCIA_CUDA(cudaMallocHost(&host, sizeof(double) * n));
      host_size = n;
    }
    return host;
  }

  void up(DeviceBuffer<double>& to, const std::vector<double>& from, size_t n) {
    FASCIA_CUDA(cudaMemcpyAsync(to.data(), from.data(), sizeof(double) * n, cudaMemcpyHostToDevice, stream));
  }
};

DeviceSampleFields::DeviceSampleFields(const Model& model) : m_impl(std::make_unique<Impl>(model)) {}

DeviceSampleFields::~DeviceSampleFields() = default;

void DeviceSampleFields::compute(const State& state, const std::vector<double>& rotations, std::vector<Field>& fields,
                                 std::vector<double>* positions) {
  Impl& m = *m_impl;
  prepare_sample_fields(m.model, fields);
  const size_t n = static_cast<size_t>(m.model.frame_count()), samples = static_cast<size_t>(m.model.sample_count());
  if (samples == 0) return;
  if (fields.size() > kMaxFields) throw std::logic_error("DeviceSampleFields: more sample fields than it places");
  FieldColumns& columns = m.columns;
  long long at = 0;
  for (size_t f = 0; f < fields.size(); ++f) {
    columns.components[f] = fields[f].components;
    columns.base[f] = at;
    at += static_cast<long long>(fields[f].values.size());
  }
  m.field_count = fields.size();
  m.out.resize(static_cast<size_t>(at));
  m.up(m.x, state.positions, 3 * n);
  m.up(m.R, rotations, 9 * n);
  m.up(m.velocities, state.velocities, 6 * n);
  k_sample_fields<<<static_cast<unsigned>((samples + kThreads - 1) / kThreads), kThreads, 0, m.stream>>>(
      m.inputs, m.x.data(), m.R.data(), m.velocities.data(), columns, m.out.data(), m.positions.data());
  FASCIA_CUDA(cudaGetLastError());
  const size_t values = static_cast<size_t>(at);
  double* host = m.staging(values + (positions ? 3 * samples : 0));
  FASCIA_CUDA(cudaMemcpyAsync(host, m.out.data(), sizeof(double) * values, cudaMemcpyDeviceToHost, m.stream));
  if (positions)
    FASCIA_CUDA(cudaMemcpyAsync(host + values, m.positions.data(), sizeof(double) * 3 * samples,
                                cudaMemcpyDeviceToHost, m.stream));
  FASCIA_CUDA(cudaStreamSynchronize(m.stream));
  // Into the fields on the calling thread's OpenMP team (about 2.7 M values per row of the pelvis
  // at 56 k samples: about 3 ms on one thread).
  const auto copy = [](const double* from, size_t count, double* to) {
#pragma omp parallel for schedule(static)
    for (long long i = 0; i < static_cast<long long>(count); ++i) to[i] = from[i];
  };
  for (size_t f = 0; f < fields.size(); ++f)
    copy(host + columns.base[f], fields[f].values.size(), fields[f].values.data());
  if (positions) {
    positions->resize(3 * samples);
    copy(host + values, 3 * samples, positions->data());
  }
}

std::vector<Field> DeviceSampleFields::frame_averages(const std::vector<unsigned char>* frames) {
  Impl& m = *m_impl;
  const int n = m.model.frame_count();
  std::vector<Field> out = measure_fields(static_cast<size_t>(n), has_fibres(m.model));
  if (m.field_count != kSampleMeasures + out.size())
    throw std::logic_error("DeviceSampleFields::frame_averages: no sample fields computed");
  AverageColumns columns{};
  long long at = 0;
  for (size_t f = 0; f < out.size(); ++f) {
    const int sample_field = kSampleMeasures + static_cast<int>(f);
    for (int c = 0; c < out[f].components; ++c) {
      if (columns.count == kMaxColumns) throw std::logic_error("DeviceSampleFields: more measure columns than it places");
      const int j = columns.count++;
      columns.in_base[j] = m.columns.base[sample_field] + c;
      columns.in_stride[j] = m.columns.components[sample_field];
      columns.out_base[j] = at + c;
      columns.out_stride[j] = out[f].components;
      columns.fibre[j] = out[f].name == "fibre_stretch";
    }
    at += static_cast<long long>(out[f].values.size());
  }
  m.averages.resize(static_cast<size_t>(at));
  if (frames)
    FASCIA_CUDA(cudaMemcpyAsync(m.mask.data(), frames->data(), frames->size(), cudaMemcpyHostToDevice, m.stream));
  const FrameAverageView view{m.rev_offsets.data(), m.rev_pairs.data(),        m.pair_samples.data(),
                              m.weights.data(),     m.volumes.data(),          m.sample_materials.data(),
                              m.fibred_material.data()};
  const long long threads = 32LL * n;  // a warp per frame
  k_frame_averages<<<static_cast<unsigned>((threads + kThreads - 1) / kThreads), kThreads, 0, m.stream>>>(
      view, n, frames ? m.mask.data() : nullptr, columns, m.out.data(), m.averages.data());
  FASCIA_CUDA(cudaGetLastError());
  at = 0;
  for (Field& f : out) {
    FASCIA_CUDA(cudaMemcpyAsync(f.values.data(), m.averages.data() + at, sizeof(double) * f.values.size(),
                                cudaMemcpyDeviceToHost, m.stream));
    at += static_cast<long long>(f.values.size());
  }
  FASCIA_CUDA(cudaStreamSynchronize(m.stream));
  return out;
}

SampleFieldsFactory device_sample_fields_factory() {
  return [](const Model& model) -> std::unique_ptr<SampleFieldsDevice> { return std::make_unique<DeviceSampleFields>(model); };
}

}  // namespace fascia::gpu
