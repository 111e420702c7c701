#include "integrate/variational_step.hpp"

#include "core/rotation.hpp"
#include "integrate/discrete_action.hpp"
#include "solve/vector_ops.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>
#include <stdexcept>

namespace fascia {

namespace {

Mat3 frame_rotation(const State& s, int i) { return rotation_matrix(load_quat(&s.orientations[4 * i])); }

// psi = log(R_end R_start^T) of frame i, world axes.
Vec3 frame_relative_rotation(const State& start, const State& end, int i) {
  return relative_rotation(load_quat(&start.orientations[4 * i]), load_quat(&end.orientations[4 * i]));
}

double free_norm(const std::vector<double>& v, const std::vector<std::uint8_t>& fixed) {
  double s = 0;
  for (size_t k = 0; k < v.size(); ++k)
    if (!fixed[k]) s += v[k] * v[k];
  return std::sqrt(s);
}

}  // namespace

VariationalStep::VariationalStep(const Model& model, StepPotential& potential, double dt)
    : m_model(model), m_potential(potential), m_dt(dt), m_start_mapping(model), m_end_mapping(model) {
  if (!(dt > 0)) throw std::invalid_argument("variational step: time step must be > 0 s");
  m_fixed = m_start_mapping.reduced_fixed(model);
  m_potential.set_static();
}

void VariationalStep::midpoint(const State& start, const State& end, State& mid) const {
  mid = end;
  const int n = m_model.frame_count();
  for (int i = 0; i < n; ++i) {
    Vec3 x;
    Quat q;
    midpoint_frame(load3(&start.positions[3 * i]), load_quat(&start.orientations[4 * i]), load3(&end.positions[3 * i]),
                   load_quat(&end.orientations[4 * i]), m_model.rotations_locked, x, q);
    store3(&mid.positions[3 * i], x);
    store_quat(&mid.orientations[4 * i], q);
  }
  m_potential.rigid_mapping().sync(mid);
}

void VariationalStep::kinetic_momenta(const State& start, const State& end, std::vector<double>& kappa) const {
  const int n = m_model.frame_count();
  kappa.assign(6 * n, 0.0);
  for (int i = 0; i < n; ++i) {
    Vec3 px, pr;
    kinetic_momentum(m_model.frame_masses[i], load_mat3(&m_model.frame_inertias[9 * i]), load3(&start.positions[3 * i]),
                     load_quat(&start.orientations[4 * i]), load3(&end.positions[3 * i]),
                     load_quat(&end.orientations[4 * i]), m_dt, m_model.rotations_locked, px, pr);
    store3(&kappa[6 * i], px);
    store3(&kappa[6 * i + 3], pr);
  }
}

void VariationalStep::midpoint_transposes(const State& start, const State& end, const std::vector<double>& g,
                                          std::vector<double>& at_g, std::vector<double>& bt_g) const {
  const int n = m_model.frame_count();
  at_g.assign(6 * n, 0.0);
  bt_g.assign(6 * n, 0.0);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) at_g[6 * i + k] = bt_g[6 * i + k] = 0.5 * g[6 * i + k];
    Vec3 at, bt;
    fascia::midpoint_transposes(load_quat(&start.orientations[4 * i]), load_quat(&end.orientations[4 * i]),
                                m_model.rotations_locked, load3(&g[6 * i + 3]), at, bt);  // (3)
    store3(&at_g[6 * i + 3], at);
    store3(&bt_g[6 * i + 3], bt);
  }
}

double VariationalStep::action(const State& start, const State& end) {
  const int n = m_model.frame_count();
  double s = 0;
  for (int i = 0; i < n; ++i)
    s += kinetic_action(m_model.frame_masses[i], load_mat3(&m_model.frame_inertias[9 * i]), load3(&start.positions[3 * i]),
                        load_quat(&start.orientations[4 * i]), load3(&end.positions[3 * i]),
                        load_quat(&end.orientations[4 * i]), m_dt, m_model.rotations_locked);
  midpoint(start, end, m_mid);
  m_potential.set_static();
  return s - m_dt * m_potential.value(m_mid);
}

void VariationalStep::action_derivatives(const State& start, const State& end, std::vector<double>& minus_d1,
                                         std::vector<double>& d2) {
  std::vector<double> kappa, g, at_g, bt_g;
  kinetic_momenta(start, end, kappa);
  midpoint(start, end, m_mid);
  m_potential.set_static();
  m_potential.gradient(m_mid, g);
  midpoint_transposes(start, end, g, at_g, bt_g);
  minus_d1 = kappa;
  d2 = kappa;
  m_start_mapping.set_state(start);
  m_start_mapping.reduce(minus_d1.data());
  m_end_mapping.set_state(end);
  m_end_mapping.reduce(d2.data());
  for (size_t k = 0; k < kappa.size(); ++k) {
    minus_d1[k] += m_dt * bt_g[k];
    d2[k] -= m_dt * at_g[k];
  }
}

void VariationalStep::momenta(const State& state, std::vector<double>& p) {
  const int n = m_model.frame_count();
  p.assign(6 * n, 0.0);
  for (int i = 0; i < n; ++i) {
    store3(&p[6 * i], m_model.frame_masses[i] * load3(&state.velocities[6 * i]));
    if (m_model.rotations_locked) continue;
    const Mat3 R = frame_rotation(state, i);
    const Mat3 I = R * load_mat3(&m_model.frame_inertias[9 * i]) * transpose(R);
    store3(&p[6 * i + 3], I * load3(&state.velocities[6 * i + 3]));
  }
  m_start_mapping.set_state(state);
  m_start_mapping.reduce(p.data());
}

void VariationalStep::set_velocities(const State& start, State& end, const std::vector<double>& p) {
  const int n = m_model.frame_count();
  const double h = m_dt;
  // Reduced mass matrix per reduced frame: diag(m I, R J R^T), plus J_a^T M_a J_a of every frame
  // attached to it, J_a = [[I, -[r_a]x], [0, I]]:
  //   J^T M J = [[m I, -m [r]x], [m [r]x, I_a - m [r]x [r]x]].
  std::vector<Eigen::Matrix<double, 6, 6>> blocks(n, Eigen::Matrix<double, 6, 6>::Zero());
  auto add_frame = [&](int target, int frame, const Vec3& r) {
    const double m = m_model.frame_masses[frame];
    const Mat3 R = frame_rotation(end, frame);
    const Mat3 I = R * load_mat3(&m_model.frame_inertias[9 * frame]) * transpose(R);
    const Mat3 S = skew(r), SS = S * S;
    Eigen::Matrix<double, 6, 6>& b = blocks[target];
    for (int a = 0; a < 3; ++a) {
      b(a, a) += m;
      for (int c = 0; c < 3; ++c) {
        b(a, 3 + c) -= m * S.m[a][c];
        b(3 + a, c) += m * S.m[a][c];
        b(3 + a, 3 + c) += (m_model.rotations_locked ? 0.0 : I.m[a][c]) - m * SS.m[a][c];
      }
    }
  };
  const std::vector<int>& mapped = m_end_mapping.mapped();
  std::vector<char> is_mapped(n, 0);
  for (int a : mapped) is_mapped[a] = 1;
  for (int i = 0; i < n; ++i)
    if (!is_mapped[i]) add_frame(i, i, Vec3{0, 0, 0});
  for (size_t k = 0; k < mapped.size(); ++k) {
    const int a = mapped[k], b = m_end_mapping.bodies()[k];
    add_frame(b, a, load3(&end.positions[3 * a]) - load3(&end.positions[3 * b]));
  }
  for (int i = 0; i < n; ++i) {
    if (is_mapped[i]) continue;
    // Fixed DOFs move as prescribed: their velocity is the step's increment over h.
    Eigen::Matrix<double, 6, 1> v, rhs;
    const Vec3 dx = (1 / h) * (load3(&end.positions[3 * i]) - load3(&start.positions[3 * i]));
    const Vec3 dr = m_model.rotations_locked ? Vec3{0, 0, 0} : (1 / h) * frame_relative_rotation(start, end, i);
    v << dx.x, dx.y, dx.z, dr.x, dr.y, dr.z;
    std::vector<int> free;
    for (int c = 0; c < 6; ++c)
      if (!m_fixed[6 * i + c]) free.push_back(c);
    if (!free.empty()) {
      const int f = static_cast<int>(free.size());
      Eigen::MatrixXd Mff(f, f);
      Eigen::VectorXd b(f);
      for (int r = 0; r < f; ++r) {
        b(r) = p[6 * i + free[r]];
        for (int c = 0; c < 6; ++c)
          if (m_fixed[6 * i + c]) b(r) -= blocks[i](free[r], c) * v(c);
        for (int c = 0; c < f; ++c) Mff(r, c) = blocks[i](free[r], free[c]);
      }
      const Eigen::LDLT<Eigen::MatrixXd> ldlt(Mff);
      if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0)) {
        std::ostringstream msg;
        msg << "variational step: frame " << i << " has no mass or inertia along a free degree of freedom";
        throw std::invalid_argument(msg.str());
      }
      const Eigen::VectorXd vf = ldlt.solve(b);
      for (int r = 0; r < f; ++r) v(free[r]) = vf(r);
    }
    for (int c = 0; c < 6; ++c) end.velocities[6 * i + c] = v(c);
  }
  m_end_mapping.set_state(end);
  m_end_mapping.expand(end.velocities.data());  // v_a = v_b + w_b x r_a, w_a = w_b
}

double VariationalStep::residual(const State& start, const State& end, const std::vector<double>& p_start,
                                 std::vector<double>& r) {
  std::vector<double> d2;
  action_derivatives(start, end, r, d2);
  for (size_t k = 0; k < r.size(); ++k) r[k] = m_fixed[k] ? 0.0 : r[k] - p_start[k];
  return free_norm(r, m_fixed);
}

LinearSystem VariationalStep::iteration_matrix(const State& start, const State& end) {
  midpoint(start, end, m_mid);
  return approximate_jacobian(start, end);
}

LinearSystem VariationalStep::approximate_jacobian(const State& start, const State& end) {
  const int n = m_model.frame_count();
  const double h = m_dt;
  m_potential.prepare_hessian(m_mid);
  LinearSystem K = m_potential.system();
  // 4 M_kin / h^2 per frame (the system below is 4 H = 4 M_kin / h^2 + K).
  m_mass_blocks.assign(36 * n, 0.0);
  for (int i = 0; i < n; ++i)
    kinetic_block(m_model.frame_masses[i], load_mat3(&m_model.frame_inertias[9 * i]), load_quat(&start.orientations[4 * i]),
                  load_quat(&end.orientations[4 * i]), 4 / (h * h), m_model.rotations_locked, &m_mass_blocks[36 * i]);
  m_end_mapping.set_state(end);
  LinearSystem sys;
  sys.size = K.size;
  sys.fixed = m_fixed.data();
  sys.apply = [this, n, K](const double* d, double* out) {
    K.apply(d, out);
    m_expanded.assign(d, d + 6 * n);
    m_end_mapping.expand(m_expanded.data());
    m_scratch.assign(6 * n, 0.0);
    for (int i = 0; i < n; ++i)
      for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c) m_scratch[6 * i + r] += m_mass_blocks[36 * i + 6 * r + c] * m_expanded[6 * i + c];
    m_end_mapping.reduce(m_scratch.data());
    for (int k = 0; k < 6 * n; ++k) out[k] += m_scratch[k];
  };
  sys.diagonal_blocks = [this, n, K](double* blocks) {
    K.diagonal_blocks(blocks);
    std::vector<double> mass = m_mass_blocks;
    m_end_mapping.reduce_diagonal_blocks(mass.data());  // no geometric term: m_end_mapping has no forces
    for (int k = 0; k < 36 * n; ++k) blocks[k] += mass[k];
    for (int a : m_end_mapping.mapped())
      for (int k = 0; k < 36; ++k) blocks[36 * a + k] = (k % 7 == 0) ? 1.0 : 0.0;
  };
  // start and end outlive the system: it is used within the linear solve it was made for.
  sys.assemble = [this, n, K, &start, &end]() {
    m_assembled_at.start = start;
    m_assembled_at.state = end;
    m_assembled_at.dt = m_dt;
    m_assembled_at.load_scale = 1;
    Eigen::SparseMatrix<double> H = K.assemble();
    std::vector<Eigen::Triplet<double>> t;
    for (int i = 0; i < n; ++i)
      for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c)
          if (m_mass_blocks[36 * i + 6 * r + c] != 0) t.emplace_back(6 * i + r, 6 * i + c, m_mass_blocks[36 * i + 6 * r + c]);
    Eigen::SparseMatrix<double> M(6 * n, 6 * n);
    M.setFromTriplets(t.begin(), t.end());
    if (!m_end_mapping.empty()) {
      const Eigen::SparseMatrix<double> P = m_end_mapping.projection(6 * n);
      const Eigen::SparseMatrix<double> Pt = P.transpose();
      M = Pt * M * P;
    }
    H += M;
    return H;
  };
  return sys;
}

namespace {

// newton()'s problem for (4): the residual r(q_{k+1}) / h (N) with the iteration matrix H (the
// system 4 H solves 4 H d = 4 rhs); no potential, so a step must decrease |r|.
class VariationalProblem {
 public:
  using Ops = HostVectorOps;
  using Vector = std::vector<double>;
  using State = fascia::State;

  VariationalProblem(VariationalStep& step, StepPotential& potential, const State& start,
                     const std::vector<double>& p_start, const std::vector<std::uint8_t>& fixed, double dt,
                     LinearSolver& solver)
      : m_step(step), m_potential(potential), m_start(start), m_p_start(p_start),
        m_ops(static_cast<int>(fixed.size()), fixed.data()), m_dt(dt), m_solver(solver) {}

  const Ops& ops() const { return m_ops; }
  bool minimises() const { return false; }
  double value(const State&) { return 0; }
  double gradient(const State& end, Vector& g) {
    const double norm_r = m_step.residual(m_start, end, m_p_start, g);
    m_ops.scale(1 / m_dt, g);
    return norm_r;
  }
  LinearResult solve(const State& end, const Vector& rhs, Vector& d, const LinearSettings& linear) {
    m_rhs = rhs;
    m_ops.scale(4.0, m_rhs);
    return m_solver.solve(m_step.iteration_matrix(m_start, end), linear, m_rhs, d);
  }
  void retract(State& q, const Vector& d, double alpha) { m_potential.retract(q, d.data(), alpha); }

 private:
  VariationalStep& m_step;
  StepPotential& m_potential;
  const State& m_start;
  const std::vector<double>& m_p_start;
  HostVectorOps m_ops;
  double m_dt;
  LinearSolver& m_solver;
  Vector m_rhs;
};

}  // namespace

NewtonResult VariationalStep::advance(const State& start, State& end, const NewtonSettings& settings,
                                      double reference_force, LinearSolver* solver, StepBackend* backend) {
  const int n = m_model.frame_count();
  const double h = m_dt;
  std::vector<double> p_start;
  momenta(start, p_start);
  // Predictor q_{k+1} = q_k (+) h v_k on the free DOFs of the reduced frames.
  {
    std::vector<double> d(6 * n, 0.0);
    for (int k = 0; k < 6 * n; ++k)
      if (!m_fixed[k]) d[k] = h * start.velocities[k];
    m_potential.retract(end, d.data(), 1.0);
  }
  // The force scale of the relative residual; newton() takes the larger of it and |r_0| / h, and
  // its last residual is r / h at the end.
  const double force_scale = std::max(reference_force, free_norm(p_start, m_fixed) / h);
  NewtonResult result;
  std::vector<double> p_end;
  if (backend) {
    result = backend->variational(start, end, h, p_start, settings, force_scale, p_end);
  } else {
    std::unique_ptr<LinearSolver> local;
    if (!solver) solver = (local = std::make_unique<LinearSolver>()).get();
    VariationalProblem problem(*this, m_potential, start, p_start, m_fixed, h, *solver);
    result = newton(problem, end, settings, force_scale);
    // (5): momenta at q_{k+1}.
    if (result.converged()) {
      std::vector<double> minus_d1;
      action_derivatives(start, end, minus_d1, p_end);
    }
  }
  m_scale = result.scale;
  m_residual_norm = result.residual * result.scale * h;
  if (!result.converged()) {
    result.message = "variational step: " + result.message;
    return result;
  }
  set_velocities(start, end, p_end);
  return result;
}

}  // namespace fascia
