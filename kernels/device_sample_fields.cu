#include "device_sample_fields.hpp"

#include "device_buffers.cuh"
#include "io/sample_point.hpp"

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

}  // namespace

static_assert(std::is_trivially_copyable_v<Material>, "materials are copied to the device as bytes");

struct DeviceSampleFields::Impl {
  const Model& model;
  cudaStream_t stream = nullptr;
  DeviceBuffer<int> offsets, frames, sample_materials;
  DeviceBuffer<double> weights, weight_gradients, rest_offsets, rest_positions, x, R, velocities, out, positions;
  DeviceBuffer<Material> materials;
  SampleInputs inputs{};

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
    materials.resize(model.materials.size());
    if (!model.materials.empty())
      FASCIA_CUDA(cudaMemcpy(materials.data(), model.materials.data(), sizeof(Material) * model.materials.size(),
                             cudaMemcpyHostToDevice));
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
  }
  ~Impl() {
    if (stream) cudaStreamDestroy(stream);
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
  FieldColumns columns{};
  long long at = 0;
  for (size_t f = 0; f < fields.size(); ++f) {
    columns.components[f] = fields[f].components;
    columns.base[f] = at;
    at += static_cast<long long>(fields[f].values.size());
  }
  m.out.resize(static_cast<size_t>(at));
  m.up(m.x, state.positions, 3 * n);
  m.up(m.R, rotations, 9 * n);
  m.up(m.velocities, state.velocities, 6 * n);
  k_sample_fields<<<static_cast<unsigned>((samples + kThreads - 1) / kThreads), kThreads, 0, m.stream>>>(
      m.inputs, m.x.data(), m.R.data(), m.velocities.data(), columns, m.out.data(), m.positions.data());
  FASCIA_CUDA(cudaGetLastError());
  for (size_t f = 0; f < fields.size(); ++f)
    FASCIA_CUDA(cudaMemcpyAsync(fields[f].values.data(), m.out.data() + columns.base[f],
                                sizeof(double) * fields[f].values.size(), cudaMemcpyDeviceToHost, m.stream));
  if (positions) {
    positions->resize(3 * samples);
    FASCIA_CUDA(cudaMemcpyAsync(positions->data(), m.positions.data(), sizeof(double) * 3 * samples,
                                cudaMemcpyDeviceToHost, m.stream));
  }
  FASCIA_CUDA(cudaStreamSynchronize(m.stream));
}

SampleFieldsFactory device_sample_fields_factory() {
  return [](const Model& model) -> std::unique_ptr<SampleFieldsDevice> { return std::make_unique<DeviceSampleFields>(model); };
}

}  // namespace fascia::gpu
