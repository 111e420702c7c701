// The CUDA backend of VolumetricElasticity (engine/mechanics/volumetric_elasticity.hpp): the CPU
// engine's Newton solver, line search, load stepping, loads, shells and rigid mapping
// (engine/integrate/step_potential.hpp) with the volumetric elasticity, the dominant cost,
// evaluated by DeviceElasticity. This is the `--backend cuda` of `fascia run` and `fascia study`.
// Host API: including this header needs no CUDA toolkit.
//
// Data moved per call (the model tables are uploaded once, at construction; N frames):
//   energy, gradient, prepare   the state up (positions, orientations, velocities: 13 N doubles);
//                               gradient: [N][6] down.
//   apply_tangent               d [N][6] up, K d [N][6] down and one host synchronisation: one
//                               round trip per CG iteration. The frame_diagonal term is added on
//                               the host, O(N).
//   tangent_diagonal_blocks     [N][36] down (computed by prepare).
// apply_tangent and tangent_diagonal_blocks use the state of the last prepare(), as the CPU
// reference does; if energy() or gradient() moved the device to another state in between, that
// state is uploaded and prepared again first (StepPotential never does this).
//
// A model without samples (shells and rigid bodies only) has no volumetric energy: every call
// returns zeros and the device is never touched.
#pragma once

#include "device_elasticity.hpp"
#include "mechanics/elasticity.hpp"
#include "mechanics/volumetric_elasticity.hpp"

#include <memory>

namespace fascia::gpu {

class CudaElasticity final : public VolumetricElasticity {
 public:
  // Uploads the model (which must outlive this object). @param threads CPU threads of
  // prepared_reference() (0 = the OpenMP default). Throws std::runtime_error without a usable
  // device when the model has samples.
  CudaElasticity(const Model& model, const DeviceOptions& options = {}, int threads = 0);

  const Model& model() const override { return m_model; }
  double energy(const State& state) override;
  double gradient(const State& state, double* gradient) override;
  double prepare(const State& state) override;
  void apply_tangent(const double* d, double* out, const double* frame_diagonal = nullptr) override;
  void tangent_diagonal_blocks(double* blocks) override;
  // A CPU Elasticity prepared at the last prepare()'s state, built on first use and prepared at
  // most once per prepare(): the assembled tangent (CHOLMOD) costs one CPU prepare per Newton
  // iteration on top of the assembly itself.
  const Elasticity& prepared_reference() override;

  // The device object; null for a model without samples.
  const DeviceElasticity* device() const { return m_device.get(); }

 private:
  // Makes the device buffers hold the prepare() of m_prepared.
  void restore_prepared();
  // The device, about to move to another state than m_prepared (energy, gradient).
  DeviceElasticity& moved();

  const Model& m_model;
  int m_threads;
  std::unique_ptr<DeviceElasticity> m_device;  // null without samples
  State m_prepared;                    // state of the last prepare()
  bool m_has_prepared = false;
  bool m_device_prepared = false;      // the device's F, P, caches and blocks are those of m_prepared
  std::unique_ptr<Elasticity> m_reference;
  bool m_reference_prepared = false;   // m_reference is prepared at m_prepared
};

// The factory for SimulationSettings::elasticity and BeamSettings::elasticity.
ElasticityFactory cuda_elasticity_factory(const DeviceOptions& options = {});

}  // namespace fascia::gpu
