// The volumetric elastic energy W = sum_s v_s psi(F_s) of a model's samples (paper §2.2) behind
// one interface, so that the integrators run on either backend (DESIGN.md, data flow):
//   - fascia::Elasticity (mechanics/elasticity.hpp), the CPU reference, in this library;
//   - fascia::gpu::CudaElasticity (kernels/cuda_elasticity.hpp), the CUDA kernels.
// StepPotential holds one through a pointer, made by an ElasticityFactory that
// SimulationSettings::elasticity carries; the engine itself never includes CUDA headers.
//
// Every implementation has the semantics of fascia::Elasticity: the same energy (J), gradient
// dW/d(theta) [N][6] (N, then N m about world axes) at theta = 0 of theta -> W(q (+) theta),
// symmetric tangent product and 6x6 diagonal blocks. Shells and rigid bodies are not part of it
// (mechanics/force_field.hpp, mechanics/rigid_mapping.hpp): they stay on the CPU.
#pragma once

#include "model/model.hpp"
#include "model/state.hpp"

#include <functional>
#include <memory>

namespace fascia {

class Elasticity;

class VolumetricElasticity {
 public:
  virtual ~VolumetricElasticity() = default;

  virtual const Model& model() const = 0;

  // W in J; +inf if a neo-Hookean sample is inverted.
  virtual double energy(const State& state) = 0;
  // W and its gradient, written (not added) to gradient [N][6]. It may prepare `state` as
  // prepare() does (the CPU's Elasticity does: its gradient is part of that work).
  virtual double gradient(const State& state, double* gradient) = 0;
  // Precomputes what the tangent products at `state` reuse; returns W. apply_tangent and
  // tangent_diagonal_blocks use the state last prepared: call prepare() after any gradient() at
  // another state.
  virtual double prepare(const State& state) = 0;
  // out = (K + D) d, d and out [N][6], K the symmetric Hessian of theta -> W(q (+) theta) at
  // theta = 0, D = diag(t_i I3, Q_i) from frame_diagonal [N][10] (t_i, then Q_i row-major), or
  // D = 0 when frame_diagonal is null.
  virtual void apply_tangent(const double* d, double* out, const double* frame_diagonal = nullptr) = 0;
  // K_ii, [N][36] row-major.
  virtual void tangent_diagonal_blocks(double* blocks) = 0;

  // A CPU Elasticity prepared at the state of the last prepare(), for what needs the per-sample
  // matrices (TangentAssembler: material_matrix, pair_jacobian). The CPU reference returns
  // itself; a device backend prepares a host copy, once per prepare() (the cost of one CPU
  // prepare, O(pairs)).
  virtual const Elasticity& prepared_reference() = 0;
};

// What an elasticity is for. The step's own (step) serves the energy, the gradient and the
// tangent of Newton's iterate. The start-of-step tangent of stiffness-proportional damping
// (damping) serves K(q_n) dq, a term of the gradient that Newton's tolerance judges, so a
// backend that stores its tangent in reduced precision makes this one in double.
enum class ElasticityUse { step, damping };

// Makes the volumetric elasticity of `model` (which must outlive it) with `threads` CPU threads
// (0 = the OpenMP default), for `use`.
using ElasticityFactory =
    std::function<std::unique_ptr<VolumetricElasticity>(const Model& model, int threads, ElasticityUse use)>;

// The CPU reference, fascia::Elasticity (double for every use).
std::unique_ptr<VolumetricElasticity> make_cpu_elasticity(const Model& model, int threads);

// factory(model, threads, use), or the CPU reference when factory is empty.
std::unique_ptr<VolumetricElasticity> make_elasticity(const ElasticityFactory& factory, const Model& model,
                                                      int threads, ElasticityUse use = ElasticityUse::step);

}  // namespace fascia
