// The step potential of engine/integrate/step_potential.hpp held and evaluated on the device: the
// volumetric elasticity (DeviceElasticity), inertia and Rayleigh mass damping
// (mechanics/frame_inertia.hpp) and the external loads (mechanics/frame_loads.hpp), summed into
// one value, gradient [N][6], Hessian product and block-Jacobi preconditioner over device arrays,
// reduced by the rigid mapping of frames attached to rigid bodies (device_rigid.hpp) as
// StepPotential reduces them: gradients, products and blocks are those of the reduced potential,
// mapped frames are fixed DOFs, and retract() keeps them on their bodies.
// The frame states it evaluates live in device slots; the host uploads a state and reads one
// back once per step.
//
// Supported: models without shells or stiffness-proportional damping (beta = 0);
// device_potential_refusal says why not otherwise.
//
// Every pointer argument is a device array of doubles of dofs() = 6N entries unless stated.
#pragma once

#include "device_elasticity.hpp"
#include "device_vector.hpp"
#include "mechanics/external_loads.hpp"

#include <memory>
#include <string>

namespace fascia::gpu {

// Empty where the device potential covers the model, else the reason (for the user).
std::string device_potential_refusal(const Model& model, double rayleigh_stiffness);

class DevicePotential {
 public:
  // State slots on the device.
  static constexpr int kCurrent = 0, kTrial = 1, kSlots = 2;

  // Uploads the model and the loads at factor 1 (the model and loads must outlive this object).
  DevicePotential(const Model& model, const ExternalLoads& loads, const DeviceOptions& options = {});
  ~DevicePotential();
  DevicePotential(const DevicePotential&) = delete;
  DevicePotential& operator=(const DevicePotential&) = delete;

  const Model& model() const { return m_model; }
  long long dofs() const { return 6LL * m_model.frame_count(); }
  VectorOps& ops();
  const std::uint8_t* fixed() const;  // [6N] 1 = fixed DOF (Model::fixed_dofs and mapped frames)

  // Load factor s of every load (ExternalLoads::scale is ignored: set it here).
  void set_load_scale(double scale);
  void set_static();
  // Backward Euler from `start` (positions, orientations, velocities), Rayleigh mass damping alpha.
  void set_dynamic(const State& start, double dt, double rayleigh_mass);

  void upload(int slot, const State& state);
  // Positions and orientations of a slot (velocities untouched).
  void download(int slot, State& state) const;
  // Delta = [x - x_n, log(R R_n^T)] [N][6] of a slot w.r.t. the step start, into host memory.
  void increments(int slot, double* delta_host);

  // Phi at a slot (J).
  double value(int slot);
  // Phi and g = dPhi/d(theta) at a slot (g unprojected).
  double gradient(int slot, double* g);
  // The Hessian at a slot for apply() and the preconditioner.
  void prepare_hessian(int slot);
  // out = H d (unprojected), with H prepared by prepare_hessian.
  void apply(const double* d, double* out);
  // Inverse 6x6 diagonal blocks of H [N][36] (block Jacobi; fixed DOFs identity rows), or null
  // before prepare_hessian.
  const double* preconditioner() const;
  // Slot `to` = slot `from` (+) scale d.
  void retract(int from, const double* d, double scale, int to);
  // Volumetric elastic energy at a slot (J).
  double elastic_energy(int slot);

  struct Impl;

 private:
  const Model& m_model;
  std::unique_ptr<Impl> m_impl;
};

}  // namespace fascia::gpu
