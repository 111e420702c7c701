#include "device_memory.hpp"

#include "core/bytes_text.hpp"
#include "device_cholesky.hpp"
#include "mechanics/rotation_stabilisation.hpp"

#include <atomic>
#include <sstream>

namespace fascia::gpu {
namespace {

std::atomic<long long> g_buffer_bytes{0};

// Bytes per item of the device objects, rounded up from what they hold for the shipped scenes and
// the pelvis at 16k samples in double storage (single stores less).
constexpr double kElasticPair = 100, kElasticSample = 1000, kElasticFrame = 200;  // DeviceElasticity
constexpr double kElasticFixed = 256 * 1024;  // its reductions' partials and grids
constexpr double kStepFrame = 2048;      // DevicePotential, DeviceFrames, the solver's vectors
constexpr double kVariationalFrame = 1024;  // DeviceVariational: two states, kinetic blocks, momenta
constexpr double kShellTriangle = 4096;  // DeviceShells: rest data, the 18 x 18 Hessian, values
constexpr double kStabilisedSample = 12 * 1536;  // DeviceStabilisation: 12 edges (12 x 12 Hessian, values)
constexpr double kColumnPair = 432;      // the factorised step: a pair's material columns (k_pair_columns)
constexpr double kBlockTerm = 8;         // a block contribution: a pair of a sample's frames
constexpr double kBlockFrame = 10240;    // the block pattern and its 6 x 6 blocks (tens per frame)
constexpr double kFieldsPair = 70, kFieldsSample = 60, kFieldsFrame = 100;  // DeviceSampleFields
constexpr double kFieldsFixed = 64 * 1024;

struct Parts {
  double elasticity = 0, step = 0, shells = 0, stabilisation = 0, factor = 0, fields = 0;
  double total() const { return elasticity + step + shells + stabilisation + factor + fields; }
};

Parts estimate_parts(const Model& model, const DeviceRun& run) {
  const double P = model.pair_count(), S = model.sample_count(), N = model.frame_count();
  double triangles = 0;
  for (const Shell& shell : model.shells) triangles += static_cast<double>(shell.triangles.size()) / 3;
  Parts parts;
  if (S > 0) parts.elasticity = kElasticPair * P + kElasticSample * S + kElasticFrame * N + kElasticFixed;
  // K(q_n) of stiffness-proportional damping; in single precision the forces' (double) too,
  // which forms no tangent blocks.
  const double elasticities = 1 + (run.start_tangent ? 1 : 0);
  parts.elasticity *= elasticities + (run.single ? 1 : 0);
  parts.step = (kStepFrame + (run.variational ? kVariationalFrame : 0)) * N;
  parts.shells = kShellTriangle * triangles;
  if (RotationStabilisation::applies(model)) {
    double stabilised = 0;  // at most 12 edges each, shared edges counted once per sample
    for (std::uint8_t f : model.samples.rotation_stabilised) stabilised += f != 0;
    parts.stabilisation = kStabilisedSample * stabilised;
  }
  if (run.factorised) {
    // Each sample adds a term to the block of every pair of its frames: k_s^2 terms.
    double terms = 0;
    const std::vector<int>& offsets = model.neighbours.offsets;
    for (size_t s = 0; s + 1 < offsets.size(); ++s) {
      const double k = offsets[s + 1] - offsets[s];
      terms += k * k;
    }
    const double n = model.dof_count();
    parts.factor = elasticities * (kColumnPair * P + kBlockTerm * terms + kBlockFrame * N) +
                   DeviceCholesky::dense_bytes(static_cast<long long>(n));
  }
  if (run.sample_rows && S > 0) parts.fields = kFieldsPair * P + kFieldsSample * S + kFieldsFrame * N + kFieldsFixed;
  return parts;
}

}  // namespace

long long device_buffer_bytes() { return g_buffer_bytes.load(); }

void count_device_buffer_bytes(long long delta) { g_buffer_bytes += delta; }

double estimate_device_bytes(const Model& model, const DeviceRun& run) { return estimate_parts(model, run).total();
}

std::string device_memory_refusal(const Model& model, const DeviceRun& run, double free, double total) {
  const Parts parts = estimate_parts(model, run);
  if (parts.total() <= free) return {};
  std::ostringstream why;
  why << "the model needs about " << bytes_text(parts.total()) << " of device memory, "
      << bytes_text(free) << " are free (of " << bytes_text(total)
      << "): the elasticity " << bytes_text(parts.elasticity) << " (" << model.sample_count() << " samples, "
      << model.pair_count() << " sample-frame pairs"
      << (run.start_tangent ? ", again for stiffness-proportional damping" : "")
      << (run.single ? ", again in double for the forces of single precision" : "") << ")";
  if (parts.factor > 0) why << ", the dense factor of " << model.dof_count() << " DOFs " << bytes_text(parts.factor);
  if (parts.shells > 0) why << ", the shells " << bytes_text(parts.shells);
  if (parts.stabilisation > 0) why << ", the rotation stabilisation " << bytes_text(parts.stabilisation);
  if (parts.fields > 0) why << ", the rows' sample fields " << bytes_text(parts.fields);
  why << "; coarsen the discretisation (sample_spacing, frame_spacing) or use a device with more memory";
  return why.str();
}

}  // namespace fascia::gpu
