#include "cuda_elasticity.hpp"

#include <algorithm>
#include <stdexcept>

namespace fascia::gpu {

CudaElasticity::CudaElasticity(const Model& model, const DeviceOptions& options, int threads)
    : m_model(model), m_threads(threads) {
  if (model.sample_count() == 0) return;
  m_device = std::make_unique<DeviceElasticity>(model, options);
}

DeviceElasticity& CudaElasticity::moved() {
  m_device_prepared = false;
  return *m_device;
}

double CudaElasticity::energy(const State& state) {
  if (!m_device) return 0.0;
  DeviceElasticity& e = moved();
  e.set_state(state);
  return e.energy();
}

double CudaElasticity::gradient(const State& state, double* gradient) {
  if (!m_device) {
    std::fill(gradient, gradient + m_model.dof_count(), 0.0);
    return 0.0;
  }
  DeviceElasticity& e = moved();
  e.set_state(state);
  return e.gradient(gradient);
}

double CudaElasticity::prepare(const State& state) {
  m_prepared = state;
  m_has_prepared = true;
  m_reference_prepared = false;
  if (!m_device) return 0.0;
  m_device->set_state(state);
  const double w = m_device->prepare();
  m_device_prepared = true;
  return w;
}

void CudaElasticity::restore_prepared() {
  if (!m_has_prepared) throw std::logic_error("CudaElasticity: tangent requested before prepare()");
  if (!m_device || m_device_prepared) return;
  m_device->set_state(m_prepared);
  m_device->prepare();
  m_device_prepared = true;
}

void CudaElasticity::apply_tangent(const double* d, double* out, const double* frame_diagonal) {
  restore_prepared();
  const int n = m_model.frame_count();
  if (m_device)
    m_device->apply_tangent(d, out);
  else
    std::fill(out, out + 6 * n, 0.0);
  if (!frame_diagonal) return;
  // out_i += [t_i dx_i, Q_i dr_i] (frame_diagonal [N][10]: t_i, then Q_i row-major).
  for (int i = 0; i < n; ++i) {
    const double* e = frame_diagonal + 10 * i;
    const double* di = d + 6 * i;
    double* o = out + 6 * i;
    for (int j = 0; j < 3; ++j) o[j] += e[0] * di[j];
    for (int r = 0; r < 3; ++r) o[3 + r] += e[1 + 3 * r] * di[3] + e[2 + 3 * r] * di[4] + e[3 + 3 * r] * di[5];
  }
}

void CudaElasticity::tangent_diagonal_blocks(double* blocks) {
  restore_prepared();
  if (m_device)
    m_device->tangent_diagonal_blocks(blocks);
  else
    std::fill(blocks, blocks + 36 * m_model.frame_count(), 0.0);
}

const Elasticity& CudaElasticity::prepared_reference() {
  if (!m_has_prepared) throw std::logic_error("CudaElasticity: prepared_reference() before prepare()");
  if (!m_reference) m_reference = std::make_unique<Elasticity>(m_model, m_threads);
  if (!m_reference_prepared) {
    m_reference->prepare(m_prepared);
    m_reference_prepared = true;
  }
  return *m_reference;
}

ElasticityFactory cuda_elasticity_factory(const DeviceOptions& options) {
  return [options](const Model& model, int threads, ElasticityUse use) -> std::unique_ptr<VolumetricElasticity> {
    // Damping's K(q_n) dq is a term of the gradient: double storage, as on the whole-step path.
    DeviceOptions chosen = options;
    if (use == ElasticityUse::damping) chosen.precision = Precision::double_precision;
    return std::make_unique<CudaElasticity>(model, chosen, threads);
  };
}

}  // namespace fascia::gpu
