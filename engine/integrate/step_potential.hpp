// The potential Newton minimises at each step (DESIGN.md):
//   static:          Phi(q) = W(q) + V(q)
//   backward Euler:  Phi(q) = 1/(2h^2) |Delta - h v_n|^2_M + 1/(2h) Delta^T (alpha M + beta K_n) Delta
//                             + W(q) + V(q)
// with W the elastic energy, V the load potential, Delta = [x - x_n, log(R R_n^T)] per frame,
// M the lumped frame masses and inertias at the step start (I_n = R_n I_0 R_n^T; gyroscopic
// terms neglected), K_n the elastic tangent at the step start (Rayleigh damping).
//
// W sums the volumetric elasticity and every other force field of the model (shells; paper
// §4.2): frames shared between objects receive all their contributions. Frames attached to rigid
// bodies are eliminated by the rigid mapping (mechanics/rigid_mapping.hpp): gradient, operator,
// blocks and assembled matrix are those of the reduced potential, and retract() keeps attached
// frames on their bodies. Stiffness-proportional damping uses the volumetric tangent only.
//
// The volumetric elasticity comes from an ElasticityFactory (mechanics/volumetric_elasticity.hpp;
// default: the CPU Elasticity), for W and for K_n alike; shells, loads, inertia and the rigid
// mapping always run here on the CPU. The assembled matrix (direct solves) is built from the
// factory's prepared_reference(), a CPU Elasticity at the same state.
//
// The value and gradient are exact (the rotational gradient carries the inverse left Jacobian of
// SO(3), J_l^{-T}(phi), since d log(exp(theta) exp(phi)) / d theta = J_l^{-1}(phi)); the Hessian
// uses J_l ~ I for the inertia and damping terms (exact for translations and at phi = 0), which
// only changes Newton's convergence rate, not the solution.
//
// Static equilibrium solves (set_equilibrium()) minimise W + S + V, S the stabilisation of the
// zero-energy rotation modes of frame hexahedra (mechanics/rotation_stabilisation.hpp; none
// without them). Dynamic steps and the variational step's V (set_static()) do not carry S: there
// the modes carry the frames' rotational inertia (docs/solvers.md).
#pragma once

#include "integrate/tangent_origin.hpp"
#include "mechanics/assembled_tangent.hpp"
#include "mechanics/elasticity.hpp"
#include "mechanics/external_loads.hpp"
#include "mechanics/force_field.hpp"
#include "mechanics/frame_inertia.hpp"
#include "mechanics/frame_loads.hpp"
#include "mechanics/rigid_mapping.hpp"
#include "mechanics/rotation_stabilisation.hpp"
#include "mechanics/volumetric_elasticity.hpp"
#include "solve/newton.hpp"

#include <memory>

namespace fascia {

class StepPotential : public Potential {
 public:
  // The model and the loads must outlive the potential and not change after its construction
  // but for the loads' factor (ExternalLoads::scale).
  // @param elasticity makes the volumetric elasticity (empty: the CPU Elasticity).
  StepPotential(const Model& model, const ExternalLoads& loads, int threads = 0,
                const ElasticityFactory& elasticity = {});

  // Static potential W + V: no inertia, no damping (also the potential of the variational step).
  void set_static();
  // Static equilibrium solve: set_static() plus S, the stabilisation of the zero-energy rotation
  // modes of frame hexahedra (mechanics/rotation_stabilisation.hpp): Phi = W + S + V.
  void set_equilibrium();
  // Backward Euler step of size dt from start (positions, orientations, velocities).
  void set_dynamic(const State& start, double dt, double rayleigh_mass, double rayleigh_stiffness);

  const Model& model() const override { return m_model; }
  double value(const State& state) override;
  double gradient(const State& state, std::vector<double>& g) override;
  void prepare_hessian(const State& state) override;
  LinearSystem system() override;
  void retract(State& state, const double* d, double scale) const override;

  // Adds a force field (the model's shells are added by the constructor).
  void add_force_field(std::unique_ptr<ForceField> field) {
    m_fields.push_back(std::move(field));
    m_mapped_gradient.held = false;
  }
  const std::vector<std::unique_ptr<ForceField>>& force_fields() const { return m_fields; }
  const RigidMapping& rigid_mapping() const { return m_mapping; }

  // The volumetric elasticity, made at its first use: a run whose steps a StepBackend solves uses
  // this potential for its prescribed motions, rigid mapping and loads only, and never makes it.
  VolumetricElasticity& elasticity();
  int threads() const { return m_threads; }  // OpenMP threads of the CPU work (0 resolved)
  const ExternalLoads& loads() const { return m_loads; }
  // The loads summed per frame (V, its gradient and blocks at the load factor loads().scale).
  const FrameLoads& frame_loads() const { return m_frame_loads; }
  // Volumetric elastic energy plus every force field's energy (J); without S.
  double elastic_energy(const State& state);

  // Delta = [x - x_n, log(R R_n^T)] of every frame w.r.t. the step start, [N][6].
  void increments(const State& state, std::vector<double>& delta) const;

  // The inputs of the last matrix system().assemble() built (tangent_origin.hpp).
  const TangentOrigin& assembled_at() const { return m_assembled_at; }

 private:
  double inertia_value(const State& state, std::vector<double>* gradient) const;
  // Prepares m_start_elasticity at m_start where the dynamic potential has stiffness damping and
  // it is not prepared yet (before inertia_value and the system's damping terms).
  void prepare_start();
  // Phi and its gradient before the rigid mapping's reduction.
  double full_gradient(const State& state, std::vector<double>& g);

  const Model& m_model;
  const ExternalLoads& m_loads;
  FrameLoads m_frame_loads;
  int m_threads;
  ElasticityFactory m_factory;
  std::unique_ptr<VolumetricElasticity> m_elasticity;
  std::unique_ptr<TangentAssembler> m_assembler;  // built on the first direct solve
  // K_n for stiffness-proportional damping, prepared at the step start when first used after
  // set_dynamic (prepare_start).
  std::unique_ptr<VolumetricElasticity> m_start_elasticity;
  bool m_start_prepared = false;
  std::vector<double> m_load_blocks;               // [N][9] rotational Hessian of V
  bool m_dynamic = false;
  State m_start;
  double m_dt = 0, m_alpha = 0, m_beta = 0;
  std::vector<double> m_world_inertia;  // [N][9] R_n I_0 R_n^T
  std::vector<double> m_scratch;
  // With a rigid mapping: the unreduced gradient of the last gradient() call and where it was
  // taken, which prepare_hessian() at that state reuses for the mapping's geometric term (Newton
  // prepares the tangent at the state whose gradient it has just evaluated).
  struct MappedGradient {
    bool held = false;
    std::vector<double> positions, orientations;  // the state it was evaluated at ([N][3], [N][4])
    double load_scale = 0;
    std::vector<double> g;  // [N][6]
  } m_mapped_gradient;
  std::vector<std::unique_ptr<ForceField>> m_fields;
  std::unique_ptr<RotationStabilisation> m_stabilisation;  // null: no frame hexahedra
  bool m_equilibrium = false;  // set_equilibrium(): Phi carries m_stabilisation
  bool m_stabilised = false;   // the prepared tangent carries it
  bool stabilised() const { return m_equilibrium && m_stabilisation; }
  RigidMapping m_mapping;
  std::vector<std::uint8_t> m_fixed;  // model.fixed_dofs plus the rigidly mapped frames
  std::vector<double> m_expanded;     // d with mapped frames filled in
  std::vector<double> m_frame_diagonal;  // [N][10] translational t_i and rotational Q_i of the system
  State m_prepared;                      // the state of the last prepare_hessian()
  TangentOrigin m_assembled_at;
};

}  // namespace fascia
