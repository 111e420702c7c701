#include "integrate/step_potential.hpp"

#include "core/rotation.hpp"
#include "mechanics/assembled_tangent.hpp"
#include "mechanics/frame_inertia.hpp"
#include "mechanics/rotation_stabilisation.hpp"
#include "mechanics/shell.hpp"

#include <cmath>
#include <omp.h>

namespace fascia {

StepPotential::StepPotential(const Model& model, const ExternalLoads& loads, int threads,
                             const ElasticityFactory& elasticity)
    : m_model(model),
      m_loads(loads),
      m_frame_loads(model, loads),
      m_threads(threads > 0 ? threads : omp_get_max_threads()),
      m_factory(elasticity),
      m_mapping(model) {
  m_load_blocks.assign(9 * model.frame_count(), 0.0);
  for (const Shell& shell : model.shells) m_fields.push_back(std::make_unique<ShellForceField>(model, shell, threads));
  if (RotationStabilisation::applies(model)) m_stabilisation = std::make_unique<RotationStabilisation>(model, threads);
  m_fixed = m_mapping.reduced_fixed(model);
}

VolumetricElasticity& StepPotential::elasticity() {
  if (!m_elasticity) m_elasticity = make_elasticity(m_factory, m_model, m_threads);
  return *m_elasticity;
}

void StepPotential::prepare_start() {
  if (!m_dynamic || !(m_beta > 0) || m_start_prepared) return;
  if (!m_start_elasticity) m_start_elasticity = make_elasticity(m_factory, m_model, m_threads, ElasticityUse::damping);
  m_start_elasticity->prepare(m_start);
  m_start_prepared = true;
}

double StepPotential::elastic_energy(const State& state) {
  double w = elasticity().energy(state);
  for (auto& field : m_fields) w += field->energy(state);
  return w;
}

void StepPotential::retract(State& state, const double* d, double scale) const {
  ::fascia::retract(m_model, state, d, scale);
  m_mapping.sync(state);
}

void StepPotential::set_static() {
  m_dynamic = false;
  m_equilibrium = false;
  m_mapped_gradient.held = false;
}

void StepPotential::set_equilibrium() {
  set_static();
  m_equilibrium = true;
}

void StepPotential::set_dynamic(const State& start, double dt, double rayleigh_mass, double rayleigh_stiffness) {
  m_dynamic = true;
  m_equilibrium = false;
  m_mapped_gradient.held = false;
  m_start = start;
  m_dt = dt;
  m_alpha = rayleigh_mass;
  m_beta = rayleigh_stiffness;
  const int n = m_model.frame_count();
  m_world_inertia.resize(9 * n);
  for (int i = 0; i < n; ++i) {
    const Mat3 R = rotation_matrix(load_quat(&start.orientations[4 * i]));
    store_mat3(&m_world_inertia[9 * i], R * load_mat3(&m_model.frame_inertias[9 * i]) * transpose(R));
  }
  m_start_prepared = false;
}

void StepPotential::increments(const State& state, std::vector<double>& delta) const {
  const int n = m_model.frame_count();
  delta.resize(6 * n);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) delta[6 * i + k] = state.positions[3 * i + k] - m_start.positions[3 * i + k];
    const Quat rel = load_quat(&state.orientations[4 * i]) * conjugate(load_quat(&m_start.orientations[4 * i]));
    store3(&delta[6 * i + 3], quat_log(rel));
  }
}

// Inertia and damping terms; adds their gradient (w.r.t. left increments) when asked.
double StepPotential::inertia_value(const State& state, std::vector<double>* gradient) const {
  const int n = m_model.frame_count();
  std::vector<double> delta;
  increments(state, delta);
  const double h = m_dt;
  std::vector<double> kd;
  if (m_beta > 0) {
    kd.resize(6 * n);
    m_start_elasticity->apply_tangent(delta.data(), kd.data());
  }
  double value = 0;
  const Vec3 zero{0, 0, 0};
  for (int i = 0; i < n; ++i) {
    const FrameIncrement d{load3(&delta[6 * i]), load3(&delta[6 * i + 3])};
    const FrameInertiaTerm t = frame_inertia_term(
        m_model.frame_masses[i], load_mat3(&m_world_inertia[9 * i]), d, load3(&m_start.velocities[6 * i]),
        load3(&m_start.velocities[6 * i + 3]), h, m_alpha, m_beta, m_beta > 0 ? load3(&kd[6 * i]) : zero,
        m_beta > 0 ? load3(&kd[6 * i + 3]) : zero);
    value += t.value;
    if (gradient) {
      double* g = gradient->data() + 6 * i;
      g[0] += t.gx.x, g[1] += t.gx.y, g[2] += t.gx.z;
      if (!m_model.rotations_locked) g[3] += t.gr.x, g[4] += t.gr.y, g[5] += t.gr.z;
    }
  }
  return value;
}

double StepPotential::value(const State& state) {
  double phi = elastic_energy(state) + m_frame_loads.value(state, m_loads.scale);
  if (stabilised()) phi += m_stabilisation->energy(state);
  if (m_dynamic) {
    prepare_start();
    phi += inertia_value(state, nullptr);
  }
  return phi;
}

double StepPotential::full_gradient(const State& state, std::vector<double>& g) {
  g.assign(m_model.dof_count(), 0.0);
  double phi = elasticity().gradient(state, g.data());
  for (auto& field : m_fields) phi += field->add_gradient(state, g.data());
  if (stabilised()) phi += m_stabilisation->add_gradient(state, g.data());
  m_frame_loads.add_gradient(state, m_loads.scale, g.data());
  phi += m_frame_loads.value(state, m_loads.scale);
  if (m_dynamic) {
    prepare_start();
    phi += inertia_value(state, &g);
  }
  return phi;
}

double StepPotential::gradient(const State& state, std::vector<double>& g) {
  const double phi = full_gradient(state, g);
  if (!m_mapping.empty()) {
    m_mapped_gradient.held = true;
    m_mapped_gradient.positions.assign(state.positions.begin(), state.positions.end());
    m_mapped_gradient.orientations.assign(state.orientations.begin(), state.orientations.end());
    m_mapped_gradient.load_scale = m_loads.scale;
    m_mapped_gradient.g = g;
    m_mapping.set_state(state);
    m_mapping.reduce(g.data());
  }
  return phi;
}

void StepPotential::prepare_hessian(const State& state) {
  m_prepared = state;
  if (!m_mapping.empty()) {  // first: the gradient pass reuses the elasticity's buffers
    const MappedGradient& last = m_mapped_gradient;
    const bool same = last.held && last.load_scale == m_loads.scale && last.positions == state.positions &&
                      last.orientations == state.orientations;
    if (!same) full_gradient(state, m_scratch);
    m_mapping.set_state(state);
    m_mapping.set_geometric(same ? last.g.data() : m_scratch.data());
  }
  elasticity().prepare(state);
  for (auto& field : m_fields) field->prepare(state);
  m_stabilised = stabilised();
  if (m_stabilised) m_stabilisation->prepare(state);
  std::fill(m_load_blocks.begin(), m_load_blocks.end(), 0.0);
  m_frame_loads.add_rotational_blocks(state, m_loads.scale, m_load_blocks.data());
}

LinearSystem StepPotential::system() {
  VolumetricElasticity* elastic = &elasticity();
  prepare_start();
  LinearSystem sys;
  sys.size = m_model.dof_count();
  sys.fixed = m_fixed.data();
  const int n = m_model.frame_count();
  // Diagonal mass-like term per frame: (1 + alpha h)/h^2 [m I3, I_n] (dynamic only).
  auto inertia_block = [this](int i, double* block6x6) {
    const double h = m_dt, c = (1 + m_alpha * h) / (h * h);
    for (int k = 0; k < 3; ++k) block6x6[6 * k + k] += c * m_model.frame_masses[i];
    for (int r = 0; r < 3; ++r)
      for (int col = 0; col < 3; ++col) block6x6[6 * (3 + r) + 3 + col] += c * m_world_inertia[9 * i + 3 * r + col];
  };
  // The load and inertia blocks once per system, [N][10] (t_i, Q_i): Elasticity::apply_tangent
  // adds diag(t_i I3, Q_i) d_i in its pass over the frames.
  m_frame_diagonal.assign(10 * n, 0.0);
  for (int i = 0; i < n; ++i) {
    double block[36] = {0};
    if (m_dynamic) inertia_block(i, block);
    double* e = &m_frame_diagonal[10 * i];
    e[0] = block[0];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) e[1 + 3 * r + c] = block[6 * (3 + r) + 3 + c] + m_load_blocks[9 * i + 3 * r + c];
  }
  sys.apply = [this, n, elastic](const double* d_reduced, double* out) {
    const double* d = d_reduced;
    if (!m_mapping.empty()) {
      m_expanded.assign(d_reduced, d_reduced + 6 * n);
      m_mapping.expand(m_expanded.data());
      d = m_expanded.data();
    }
    elastic->apply_tangent(d, out, m_frame_diagonal.data());
    for (const auto& field : m_fields) field->add_tangent(d, out);
    if (m_stabilised) m_stabilisation->add_tangent(d, out);
    if (m_dynamic && m_beta > 0) {
      m_scratch.resize(6 * n);
      m_start_elasticity->apply_tangent(d, m_scratch.data());
      for (int k = 0; k < 6 * n; ++k) out[k] += m_beta / m_dt * m_scratch[k];
    }
    if (!m_mapping.empty()) {
      m_mapping.reduce(out);
      m_mapping.add_geometric(d_reduced, out);
    }
  };
  sys.diagonal_blocks = [this, n, inertia_block, elastic](double* blocks) {
    elastic->tangent_diagonal_blocks(blocks);
    std::vector<double> start_blocks;
    if (m_dynamic && m_beta > 0) {
      start_blocks.resize(36 * n);
      m_start_elasticity->tangent_diagonal_blocks(start_blocks.data());
    }
    for (int i = 0; i < n; ++i) {
      double* b = blocks + 36 * i;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) b[6 * (3 + r) + 3 + c] += m_load_blocks[9 * i + 3 * r + c];
      if (m_dynamic) {
        inertia_block(i, b);
        if (m_beta > 0)
          for (int k = 0; k < 36; ++k) b[k] += m_beta / m_dt * start_blocks[36 * i + k];
      }
    }
    for (const auto& field : m_fields) field->add_diagonal_blocks(blocks);
    if (m_stabilised) m_stabilisation->add_diagonal_blocks(blocks);
    if (!m_mapping.empty()) m_mapping.reduce_diagonal_blocks(blocks);
  };
  sys.assemble = [this, n, inertia_block, elastic]() {
    m_assembled_at.start = m_dynamic ? m_start : State{};
    m_assembled_at.state = m_prepared;
    m_assembled_at.dt = m_dynamic ? m_dt : 0.0;
    m_assembled_at.load_scale = m_loads.scale;
    // The load and inertia blocks (every entry, so that the positions stay those of the last
    // assembly), then the fields' entries, summed into the elastic tangent's pattern.
    std::vector<Eigen::Triplet<double>> t;
    for (int i = 0; i < n; ++i) {
      double block[36] = {0};
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) block[6 * (3 + r) + 3 + c] = m_load_blocks[9 * i + 3 * r + c];
      if (m_dynamic) inertia_block(i, block);
      for (int a = 0; a < 6; ++a)
        for (int b = 0; b < 6; ++b) t.emplace_back(6 * i + a, 6 * i + b, block[6 * a + b]);
    }
    for (const auto& field : m_fields) field->add_triplets(t);
    if (m_stabilised) m_stabilisation->add_triplets(t);
    if (!m_assembler) m_assembler = std::make_unique<TangentAssembler>(m_model, t);
    Eigen::SparseMatrix<double> H = m_assembler->assemble(elastic->prepared_reference(), t);
    if (m_dynamic && m_beta > 0) H += (m_beta / m_dt) * assemble_tangent(m_start_elasticity->prepared_reference());
    if (!m_mapping.empty()) {
      const Eigen::SparseMatrix<double> P = m_mapping.projection(6 * n);
      const Eigen::SparseMatrix<double> Pt = P.transpose();
      Eigen::SparseMatrix<double> reduced = Pt * H * P;
      reduced += m_mapping.geometric_matrix(6 * n);
      return reduced;
    }
    return H;
  };
  return sys;
}

}  // namespace fascia
