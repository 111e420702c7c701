// The step potential of engine/integrate/step_potential.hpp held and evaluated on the device: the
// volumetric elasticity (DeviceElasticity), the shells (device_shell.hpp), in static equilibria
// the rotation stabilisation of frame hexahedra (device_stabilisation.hpp), inertia and Rayleigh
// mass damping (mechanics/frame_inertia.hpp) and the external loads (mechanics/frame_loads.hpp),
// summed into one value, gradient [N][6], Hessian product and block-Jacobi preconditioner over
// device arrays, reduced by the rigid mapping of frames attached to rigid bodies (device_rigid.hpp) as
// StepPotential reduces them: gradients, products and blocks are those of the reduced potential,
// mapped frames are fixed DOFs, and retract() keeps them on their bodies.
// The states it evaluates are device states (device_frames.hpp); the host uploads a state and
// reads one back once per step.
//
// Supported: every model; stiffness-proportional damping (beta > 0) keeps a second elasticity,
// prepared at each step's start (twice the elasticity's device memory).
//
// Every pointer argument is a device array of doubles of dofs() = 6N entries unless stated.
#pragma once

#include "device_elasticity.hpp"
#include "device_frames.hpp"
#include "device_vector.hpp"
#include "mechanics/external_loads.hpp"

#include <memory>
#include <string>
#include <vector>

namespace fascia::gpu {

class DevicePotential {
 public:
  // Uploads the model and the loads at factor 1 (the model and loads must outlive this object).
  // rayleigh_stiffness: beta (s) of the backward-Euler steps' stiffness-proportional damping,
  // beta / h K(q_n) in the Hessian and its forces in the frame terms (StepPotential::set_dynamic).
  DevicePotential(const Model& model, const ExternalLoads& loads, const DeviceOptions& options = {},
                  double rayleigh_stiffness = 0);
  ~DevicePotential();
  DevicePotential(const DevicePotential&) = delete;
  DevicePotential& operator=(const DevicePotential&) = delete;

  const Model& model() const { return m_model; }
  long long dofs() const { return 6LL * m_model.frame_count(); }
  const VectorOps& ops() const;
  const std::uint8_t* fixed() const;  // [6N] 1 = fixed DOF (Model::fixed_dofs and mapped frames)
  // A device state of this model on its stream, uninitialised.
  DeviceFrames make_state() const;

  // Load factor s of every load (ExternalLoads::scale is ignored: set it here).
  void set_load_scale(double scale);
  void set_static();
  // Static equilibrium solve: set_static() plus the rotation stabilisation (StepPotential::
  // set_equilibrium).
  void set_equilibrium();
  // Backward Euler from `start` (positions, orientations, velocities), Rayleigh mass damping alpha
  // and the constructor's stiffness-proportional damping (its K(q_n) prepared here).
  void set_dynamic(const State& start, double dt, double rayleigh_mass);

  // A block-diagonal term E [N][36] (a device array the caller keeps; null: none) of the reduced
  // unknowns, added to the Hessian prepare_hessian prepares: in apply(), the block-Jacobi blocks
  // and tangent_blocks(). The variational step's kinetic matrix (device_variational.hpp);
  // set_static, set_equilibrium and set_dynamic clear it.
  void set_frame_blocks(const double* blocks);

  // Delta = [x - x_n, log(R R_n^T)] [N][6] of q w.r.t. the step start, into host memory.
  void increments(const DeviceFrames& q, double* delta_host);

  // Phi at q (J).
  double value(const DeviceFrames& q);
  // Phi and g = dPhi/d(theta) at q (g unprojected).
  double gradient(const DeviceFrames& q, double* g);
  // The Hessian at q for apply(), tangent_blocks() and, with `preconditioner`, the block-Jacobi
  // preconditioner() (whose diagonal blocks are most of the elasticity's preparation: a solve
  // preconditioned by the Cholesky factor leaves them out).
  void prepare_hessian(const DeviceFrames& q, bool preconditioner = true);
  // out = H d (unprojected), with H prepared by prepare_hessian.
  void apply(const double* d, double* out);
  // The blocks of the Hessian prepared by prepare_hessian for the block pattern set by
  // set_tangent_blocks (integrate/tangent_probing.hpp: host CSR block_offsets [N+1], block_frames
  // [B], and each frame's diagonal block or -1) into blocks [B][36], a device array: the
  // elasticity's (DeviceElasticity::tangent_blocks_on_device), the shells' (DeviceShells::
  // add_tangent_blocks) and the frame terms on the diagonal blocks, each block (a, b) with b <= a
  // (the others zero).
  void set_tangent_blocks(const std::vector<int>& block_offsets, const std::vector<int>& block_frames,
                          const std::vector<int>& diagonal_blocks);
  void tangent_blocks(double* blocks);
  // Inverse 6x6 diagonal blocks of H [N][36] (block Jacobi; fixed DOFs identity rows), or null
  // before prepare_hessian.
  const double* preconditioner() const;
  // q <- q (+) scale d, attached frames back on their bodies.
  void retract(DeviceFrames& q, const double* d, double scale);
  // Elastic energy at q (J).
  double elastic_energy(const DeviceFrames& q);

  struct Impl;

 private:
  const Model& m_model;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace fascia::gpu
