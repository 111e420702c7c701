#include "solve/newton.hpp"

#include "solve/vector_ops.hpp"

#include <cmath>
#include <memory>

namespace fascia {

double free_norm(const Model& model, const std::vector<double>& g) {
  double s = 0;
  for (size_t k = 0; k < g.size(); ++k)
    if (!model.fixed_dofs[k]) s += g[k] * g[k];
  return std::sqrt(s);
}

namespace {

// newton()'s problem for a CPU Potential: host vectors, the model's fixed DOFs (a Potential's
// reduced gradient is zero on the frames its constraints eliminate), the linear solve by `solver`.
class HostPotentialProblem {
 public:
  using Ops = HostVectorOps;
  using Vector = std::vector<double>;
  using State = fascia::State;

  HostPotentialProblem(Potential& potential, LinearSolver& solver)
      : m_potential(potential),
        m_solver(solver),
        m_ops(potential.model().dof_count(), potential.model().fixed_dofs.data()) {}

  const Ops& ops() const { return m_ops; }
  bool minimises() const { return true; }
  double value(const State& q) { return m_potential.value(q); }
  double gradient(const State& q, Vector& g) {
    const double phi = m_potential.gradient(q, g);
    m_ops.project(g);
    return phi;
  }
  LinearResult solve(const State& q, const Vector& rhs, Vector& d, const LinearSettings& linear) {
    m_potential.prepare_hessian(q);
    return m_solver.solve(m_potential.system(), linear, rhs, d);
  }
  void retract(State& q, const Vector& d, double alpha) { m_potential.retract(q, d.data(), alpha); }

 private:
  Potential& m_potential;
  LinearSolver& m_solver;
  HostVectorOps m_ops;
};

}  // namespace

NewtonResult minimise(Potential& potential, State& state, const NewtonSettings& settings, double reference_force,
                      LinearSolver* solver) {
  std::unique_ptr<LinearSolver> local;
  if (!solver) solver = (local = std::make_unique<LinearSolver>()).get();
  HostPotentialProblem problem(potential, *solver);
  return newton(problem, state, settings, reference_force);
}

NewtonResult minimise_load_stepping(Potential& potential, State& state, const NewtonSettings& settings,
                                    const LoadStepping& stepping, const std::function<double(double)>& set_load_factor,
                                    LinearSolver* solver) {
  std::unique_ptr<LinearSolver> local;
  if (!solver) solver = (local = std::make_unique<LinearSolver>()).get();
  HostPotentialProblem problem(potential, *solver);
  return newton_load_stepping(problem, state, settings, stepping, set_load_factor);
}

}  // namespace fascia
