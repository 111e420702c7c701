#include "device_potential.hpp"

#include "device_buffers.cuh"
#include "device_rigid.hpp"
#include "device_shell.hpp"
#include "device_stabilisation.hpp"
#include "device_vector.cuh"
#include "mechanics/frame_inertia.hpp"
#include "mechanics/frame_loads.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace fascia::gpu {
namespace {

// Per-frame kernels use one thread per frame in a grid that strides over the frames.
constexpr int kFrameThreads = 128;
int frame_grid(int n) { return std::max(1, std::min((n + kFrameThreads - 1) / kFrameThreads, 65535)); }

__device__ Mat3 load_mat3_d(const double* p) { return load_mat3(p); }

// The frame terms of the step potential besides the elasticity: loads at factor `scale` and, with
// `start_x` non-null, inertia and mass damping (frame_inertia_term). Adds the gradient to g where
// g is non-null; block b of the fixed reduction grid writes its frames' value sum to partials[b].
struct FrameTerms {
  int n;
  bool locked;  // rotations locked: no rotational inertia gradient (those DOFs are fixed)
  const double* f;        // [N][3] loads at factor 1
  const double* C;        // [N][9]
  double scale;
  const double* start_x;  // [N][3], null: static
  const double* start_q;  // [N][4]
  const double* start_v;  // [N][6]
  const double* masses;   // [N]
  const double* inertia;  // [N][9] world inertia at the step start
  double h, alpha;
  double beta;            // stiffness-proportional damping (s), with kd
  const double* kd;       // [N][6] K(q_n) Delta, null: no stiffness-proportional damping
};

__global__ void k_frame_terms(FrameTerms t, const double* x, const double* q, double* g, double* partials) {
  __shared__ double shared[1][kReduceThreads];
  double sum[1] = {0.0};
  for (int i = blockIdx.x * kReduceThreads + threadIdx.x; i < t.n; i += kReduceBlocks * kReduceThreads) {
    const Vec3 xi = load3(x + 3 * i);
    const Quat qi = load_quat(q + 4 * i);
    const Mat3 R = rotation_matrix(qi);
    const Vec3 f = load3(t.f + 3 * i);
    const Mat3 C = load_mat3_d(t.C + 9 * i);
    sum[0] += frame_load_value(f, C, xi, R, t.scale);
    Vec3 gx, gr;
    frame_load_gradient(f, C, R, t.scale, gx, gr);
    if (t.start_x) {
      const Vec3 zero{0, 0, 0};
      const FrameIncrement d = frame_increment(xi, qi, load3(t.start_x + 3 * i), load_quat(t.start_q + 4 * i));
      const FrameInertiaTerm in = frame_inertia_term(
          t.masses[i], load_mat3_d(t.inertia + 9 * i), d, load3(t.start_v + 6 * i), load3(t.start_v + 6 * i + 3), t.h,
          t.alpha, t.kd ? t.beta : 0.0, t.kd ? load3(t.kd + 6 * i) : zero, t.kd ? load3(t.kd + 6 * i + 3) : zero);
      sum[0] += in.value;
      gx += in.gx;
      if (!t.locked) gr += in.gr;
    }
    if (g) {
      double* gi = g + 6 * i;
      gi[0] += gx.x, gi[1] += gx.y, gi[2] += gx.z;
      gi[3] += gr.x, gi[4] += gr.y, gi[5] += gr.z;
    }
  }
  block_sum<1>(sum, shared);
  if (threadIdx.x == 0) partials[blockIdx.x] = sum[0];
}

// The frame diagonal of the Hessian besides the elasticity, [N][10]: the translational scalar t_i
// and the rotational block Q_i (inertia (1 + alpha h)/h^2 [m I3, I] when dynamic, plus the loads'
// rotational block).
__global__ void k_frame_diagonal(FrameTerms t, const double* q, double* diag) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= t.n) return;
  const Mat3 R = rotation_matrix(load_quat(q + 4 * i));
  Mat3 Q = frame_load_rotational_block(load_mat3_d(t.C + 9 * i), R, t.scale);
  double tr = 0;
  if (t.start_x) {
    const double c = frame_inertia_scale(t.h, t.alpha);
    tr = c * t.masses[i];
    Q += c * load_mat3_d(t.inertia + 9 * i);
  }
  double* e = diag + 10 * i;
  e[0] = tr;
  store_mat3(e + 1, Q);
}

// out_i += [t_i d_x, Q_i d_r].
__global__ void k_add_frame_diagonal(int n, const double* diag, const double* d, double* out) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const double* e = diag + 10 * i;
  const Vec3 dr = load3(d + 6 * i + 3);
  const Vec3 qr = load_mat3_d(e + 1) * dr;
  double* o = out + 6 * i;
  o[0] += e[0] * d[6 * i], o[1] += e[0] * d[6 * i + 1], o[2] += e[0] * d[6 * i + 2];
  o[3] += qr.x, o[4] += qr.y, o[5] += qr.z;
}

// B [36] += a frame's diagonal e [10] (k_frame_diagonal's t_i, then Q_i row-major): t_i I3 on the
// translations, Q_i on the rotations.
__device__ void add_frame_block(const double* e, double* B) {
  for (int k = 0; k < 3; ++k) B[7 * k] += e[0];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) B[6 * (3 + r) + 3 + c] += e[1 + 3 * r + c];
}

// blocks[p] += the frame diagonal of frame i (k_frame_diagonal's [t_i I3, Q_i]), p =
// diagonal_blocks[i] (-1: none).
__global__ void k_add_frame_blocks(int n, const int* diagonal_blocks, const double* diag, double* blocks) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n || diagonal_blocks[i] < 0) return;
  add_frame_block(diag + 10 * i, blocks + 36LL * diagonal_blocks[i]);
}

// blocks[p] += E_i [36], p = diagonal_blocks[i] (-1: none).
__global__ void k_add_blocks(int n, const int* diagonal_blocks, const double* E, double* blocks) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n || diagonal_blocks[i] < 0) return;
  double* B = blocks + 36LL * diagonal_blocks[i];
  for (int k = 0; k < 36; ++k) B[k] += E[36 * i + k];
}

// The diagonal blocks of H [N][36]: the elastic block (null: none) plus the frame diagonal.
__global__ void k_diagonal_blocks(int n, const double* elastic, const double* diag, double* blocks) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  double* B = blocks + 36 * i;
  for (int k = 0; k < 36; ++k) B[k] = elastic ? elastic[36 * i + k] : 0.0;
  add_frame_block(diag + 10 * i, B);
}

// Inverse 6x6 diagonal blocks as the CPU's block Jacobi (engine/solve/linear_solver.cpp): fixed
// DOFs get rows and columns of the largest diagonal entry; a block that is not positive definite
// (Cholesky meets a pivot <= 0) is replaced by the inverse of its absolute diagonal.
__global__ void k_block_jacobi(int n, const double* blocks, const std::uint8_t* fixed, double* inverse) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  double B[6][6];
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) B[r][c] = blocks[36 * i + 6 * r + c];
  double largest = 0;
  for (int k = 0; k < 6; ++k) largest = fmax(largest, fabs(B[k][k]));
  if (largest == 0) largest = 1;
  for (int k = 0; k < 6; ++k)
    if (fixed[6 * i + k]) {
      for (int c = 0; c < 6; ++c) B[k][c] = B[c][k] = 0;
      B[k][k] = largest;
    }
  // Cholesky B = L L^T (lower triangle of B).
  double L[6][6] = {};
  bool ok = true;
  for (int j = 0; j < 6 && ok; ++j) {
    double s = B[j][j];
    for (int k = 0; k < j; ++k) s -= L[j][k] * L[j][k];
    if (!(s > 0)) {
      ok = false;
      break;
    }
    L[j][j] = sqrt(s);
    for (int r = j + 1; r < 6; ++r) {
      double t = B[r][j];
      for (int k = 0; k < j; ++k) t -= L[r][k] * L[j][k];
      L[r][j] = t / L[j][j];
    }
  }
  double* out = inverse + 36 * i;
  if (!ok) {
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) out[6 * r + c] = r == c ? 1.0 / fmax(fabs(B[r][r]), 1e-12 * largest) : 0.0;
    return;
  }
  // L^{-1} (lower), then B^{-1} = L^{-T} L^{-1}.
  double Li[6][6] = {};
  for (int c = 0; c < 6; ++c) {
    Li[c][c] = 1.0 / L[c][c];
    for (int r = c + 1; r < 6; ++r) {
      double s = 0;
      for (int k = c; k < r; ++k) s -= L[r][k] * Li[k][c];
      Li[r][c] = s / L[r][r];
    }
  }
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) {
      double s = 0;
      for (int k = (r > c ? r : c); k < 6; ++k) s += Li[k][r] * Li[k][c];
      out[6 * r + c] = s;
    }
}

// q <- q (+) scale d (model/state.cpp, retract).
__global__ void k_retract(int n, bool locked, const double* d, double scale, double* x, double* q) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  for (int k = 0; k < 3; ++k) x[3 * i + k] += scale * d[6 * i + k];
  if (locked) return;
  const Vec3 dr{scale * d[6 * i + 3], scale * d[6 * i + 4], scale * d[6 * i + 5]};
  store_quat(q + 4 * i, apply_increment(load_quat(q + 4 * i), dr));
}

__global__ void k_increments(int n, const double* x, const double* q, const double* x0, const double* q0,
                             double* delta) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const FrameIncrement d = frame_increment(load3(x + 3 * i), load_quat(q + 4 * i), load3(x0 + 3 * i),
                                           load_quat(q0 + 4 * i));
  store3(delta + 6 * i, d.dx);
  store3(delta + 6 * i + 3, d.phi);
}

// R_n I_0 R_n^T per frame.
__global__ void k_world_inertia(int n, const double* q, const double* I0, double* I) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const Mat3 R = rotation_matrix(load_quat(q + 4 * i));
  store_mat3(I + 9 * i, R * load_mat3_d(I0 + 9 * i) * transpose(R));
}

void check() { FASCIA_CUDA(cudaGetLastError()); }

}  // namespace

// The stream of a potential: the elasticity's where the model has samples, else its own.
struct PotentialStream {
  PotentialStream(const Model& model, const DeviceOptions& options) {
    if (model.sample_count() > 0) {
      elasticity = std::make_unique<DeviceElasticity>(model, options);
      stream = static_cast<cudaStream_t>(elasticity->stream());
    } else {
      FASCIA_CUDA(cudaStreamCreateWithFlags(&own, cudaStreamNonBlocking));
      stream = own;
    }
  }
  ~PotentialStream() {
    if (own) cudaStreamDestroy(own);
  }
  PotentialStream(const PotentialStream&) = delete;
  PotentialStream& operator=(const PotentialStream&) = delete;
  std::unique_ptr<DeviceElasticity> elasticity;  // null without samples
  cudaStream_t stream = nullptr, own = nullptr;
};

struct DevicePotential::Impl {
  Impl(const Model& model, const ExternalLoads& loads, const DeviceOptions& options, double rayleigh_stiffness)
      : device(model, options),
        elasticity(device.elasticity.get()),
        ops(device.stream),
        mapping(model),
        shells(model),
        stabilisation(model) {
    const int n = model.frame_count();
    stream = ops.stream();
    const FrameLoads frame_loads(model, loads);
    load_f.upload(frame_loads.forces());
    load_C.upload(frame_loads.moments());
    std::vector<double> frame_masses = model.frame_masses, frame_inertias = model.frame_inertias;
    frame_masses.resize(n, 0.0);
    frame_inertias.resize(9 * static_cast<size_t>(n), 0.0);
    masses.upload(frame_masses);
    inertia0.upload(frame_inertias);
    fixed.upload(mapping.reduced_fixed());
    start_x.resize(3 * static_cast<size_t>(n));
    start_q.resize(4 * static_cast<size_t>(n));
    start_v.resize(6 * static_cast<size_t>(n));
    inertia.resize(9 * static_cast<size_t>(n));
    diag.resize(10 * static_cast<size_t>(n));
    minv.resize(36 * static_cast<size_t>(n));
    scratch.resize(6 * static_cast<size_t>(n));
    blocks.resize(36 * static_cast<size_t>(n));
    if (!mapping.empty()) {
      expanded.resize(6 * static_cast<size_t>(n));
      full_g.resize(6 * static_cast<size_t>(n));
    }
    terms.n = n;
    terms.locked = model.rotations_locked;
    terms.f = load_f.data();
    terms.C = load_C.data();
    terms.scale = 1.0;
    terms.masses = masses.data();
    terms.inertia = inertia.data();
    terms.start_q = start_q.data();
    terms.start_v = start_v.data();
    if (rayleigh_stiffness > 0 && elasticity) {
      terms.beta = rayleigh_stiffness;
      // Its product K(q_n) Delta(q) is part of the gradient: double storage, as the gradients'.
      start_elasticity = std::make_unique<DeviceElasticity>(model, DeviceOptions{}, stream);
      kd.resize(6 * static_cast<size_t>(n));
      damped_product.resize(6 * static_cast<size_t>(n));
    }
  }

  // Dynamic steps with stiffness-proportional damping: kd = K(q_n) Delta(q) for the frame terms.
  bool damped() const { return dynamic && start_elasticity; }
  void damping_forces(const DeviceFrames& s) {
    if (!damped()) return;
    const int n = static_cast<int>(kd.size() / 6);
    k_increments<<<frame_grid(n), kFrameThreads, 0, stream>>>(n, s.positions(), s.orientations(), start_x.data(),
                                                               start_q.data(), scratch.data());
    check();
    start_elasticity->apply_tangent_on_device(scratch.data(), kd.data());
  }

  // Makes `e` evaluate s.
  static void select(DeviceElasticity& e, const DeviceFrames& s) { e.set_state_on_device(s.positions(), s.orientations()); }

  // Phi and its gradient at s before the rigid mapping's reduction, into g: the terms' energies
  // summed on the host in a fixed order (elasticity, shells, stabilisation, frame terms), read
  // back together.
  double full_gradient(const DeviceFrames& s, double* g, long long dofs) {
    if (elasticity)
      elasticity_term(s, g);
    else
      ops.fill(g, 0.0, dofs);
    shells.add_gradient(s.positions(), s.orientations(), g, ops);
    if (equilibrium) stabilisation.add_gradient(s.orientations(), g, ops);
    damping_forces(s);
    k_frame_terms<<<kReduceBlocks, kReduceThreads, 0, stream>>>(terms, s.positions(), s.orientations(), g,
                                                              ops.partials());
    check();
    ops.finish_pending();
    return ops.read_pending();
  }

  // The elastic energy at s (elasticity, shells) as pending terms of ops.
  void elastic_energy(const DeviceFrames& s) {
    if (elasticity) elasticity_term(s, nullptr);
    shells.energy(s.positions(), s.orientations(), ops);
  }

  // The elasticity's force pass at s (the gradient into g where it is set) and its energy as the
  // next pending term of ops.
  void elasticity_term(const DeviceFrames& s, double* g) {
    select(*elasticity, s);
    elasticity->gradient_on_device(g);
    ops.copy_pending(elasticity->energy_on_device());
  }

  PotentialStream device;
  DeviceElasticity* elasticity;  // null without samples
  long long block_count = 0;     // blocks of the tangent block pattern (set_tangent_blocks)
  VectorOps ops;
  DeviceRigidMapping mapping;
  DeviceShells shells;
  DeviceStabilisation stabilisation;  // carried by static equilibria (set_equilibrium)
  cudaStream_t stream = nullptr;
  bool dynamic = false;
  bool equilibrium = false;  // Phi carries the stabilisation
  bool stabilised = false;   // the prepared Hessian carries it
  // Stiffness-proportional damping (terms.beta > 0): K(q_n), the elasticity prepared at the step
  // start, on the same stream; beta / h K(q_n) in the Hessian. Its diagonal blocks (block Jacobi)
  // and its tangent blocks (the dense factor) are formed at a step's first use.
  std::unique_ptr<DeviceElasticity> start_elasticity;
  DeviceBuffer<double> kd, damped_product, start_blocks;  // [N][6], [N][6], the pattern's [B][36]
  bool start_diagonal = false, start_blocks_formed = false;  // formed for this step
  bool preconditioned = false;  // minv holds the block-Jacobi inverse of the last prepare_hessian
  const double* frame_blocks = nullptr;  // [N][36] set_frame_blocks' E, null: none
  FrameTerms terms{};
  DeviceBuffer<double> load_f, load_C, masses, inertia0, inertia, start_x, start_q, start_v, diag, minv, scratch, blocks;
  DeviceBuffer<double> expanded, full_g;  // rigid mapping: d with mapped frames filled in, unreduced gradient
  DeviceBuffer<std::uint8_t> fixed;
  DeviceBuffer<int> diagonal_blocks;  // [N] each frame's block (a, a) of the tangent block pattern, -1: none
};

DevicePotential::DevicePotential(const Model& model, const ExternalLoads& loads, const DeviceOptions& options,
                                 double rayleigh_stiffness)
    : m_model(model), m_impl(std::make_unique<Impl>(model, loads, options, rayleigh_stiffness)) {}

DevicePotential::~DevicePotential() = default;

const VectorOps& DevicePotential::ops() const { return m_impl->ops; }
DeviceFrames DevicePotential::make_state() const { return DeviceFrames(m_model.frame_count(), m_impl->stream); }
const std::uint8_t* DevicePotential::fixed() const { return m_impl->fixed.data(); }

void DevicePotential::set_load_scale(double scale) { m_impl->terms.scale = scale; }

void DevicePotential::set_static() {
  m_impl->frame_blocks = nullptr;
  m_impl->dynamic = false;
  m_impl->equilibrium = false;
  m_impl->terms.start_x = nullptr;
  m_impl->terms.kd = nullptr;
}

void DevicePotential::set_equilibrium() {
  set_static();
  m_impl->equilibrium = !m_impl->stabilisation.empty();
}

void DevicePotential::set_dynamic(const State& start, double dt, double rayleigh_mass) {
  Impl& m = *m_impl;
  const int n = m_model.frame_count();
  m.frame_blocks = nullptr;
  m.dynamic = true;
  m.equilibrium = false;
  m.start_x.upload(start.positions, m.stream);
  m.start_q.upload(start.orientations, m.stream);
  std::vector<double> v = start.velocities;
  v.resize(6 * static_cast<size_t>(n), 0.0);
  m.start_v.upload(v, m.stream);
  k_world_inertia<<<frame_grid(n), kFrameThreads, 0, m.stream>>>(n, m.start_q.data(), m.inertia0.data(),
                                                                  m.inertia.data());
  check();
  m.terms.start_x = m.start_x.data();
  m.terms.h = dt;
  m.terms.alpha = rayleigh_mass;
  m.terms.kd = nullptr;
  if (!m.start_elasticity) return;
  m.start_elasticity->set_state(start);
  m.start_elasticity->prepare_on_device(false);
  m.start_diagonal = m.start_blocks_formed = false;
  m.terms.kd = m.kd.data();
}

void DevicePotential::set_frame_blocks(const double* blocks) { m_impl->frame_blocks = blocks; }

void DevicePotential::increments(const DeviceFrames& q, double* delta_host) {
  Impl& m = *m_impl;
  const int n = m_model.frame_count();
  k_increments<<<frame_grid(n), kFrameThreads, 0, m.stream>>>(n, q.positions(), q.orientations(), m.start_x.data(),
                                                               m.start_q.data(), m.scratch.data());
  check();
  FASCIA_CUDA(cudaStreamSynchronize(m.stream));
  m.scratch.download(delta_host);
}

double DevicePotential::elastic_energy(const DeviceFrames& q) {
  m_impl->elastic_energy(q);
  return m_impl->ops.read_pending();
}

double DevicePotential::value(const DeviceFrames& q) {
  Impl& m = *m_impl;
  m.elastic_energy(q);
  if (m.equilibrium) m.stabilisation.energy(q.orientations(), m.ops);
  m.damping_forces(q);
  k_frame_terms<<<kReduceBlocks, kReduceThreads, 0, m.stream>>>(m.terms, q.positions(), q.orientations(), nullptr,
                                                                m.ops.partials());
  check();
  m.ops.finish_pending();
  return m.ops.read_pending();
}

double DevicePotential::gradient(const DeviceFrames& q, double* g) {
  Impl& m = *m_impl;
  const double phi = m.full_gradient(q, g, dofs());
  if (!m.mapping.empty()) {
    m.mapping.set_state(q.positions(), m.stream);
    m.mapping.reduce(g, m.stream);
  }
  return phi;
}

void DevicePotential::prepare_hessian(const DeviceFrames& q, bool preconditioner) {
  Impl& m = *m_impl;
  const int n = m_model.frame_count();
  if (!m.mapping.empty()) {  // first: the gradient pass reuses the elasticity's buffers
    m.full_gradient(q, m.full_g.data(), dofs());
    m.mapping.set_state(q.positions(), m.stream);
    m.mapping.set_geometric(m.full_g.data(), m.stream);
  }
  if (m.elasticity) {
    m.select(*m.elasticity, q);
    m.elasticity->prepare_on_device(preconditioner);
  }
  m.shells.prepare(q.positions(), q.orientations(), m.stream);
  m.stabilised = m.equilibrium;
  if (m.stabilised) m.stabilisation.prepare(q.orientations(), m.stream);
  k_frame_diagonal<<<frame_grid(n), kFrameThreads, 0, m.stream>>>(m.terms, q.orientations(), m.diag.data());
  check();
  m.preconditioned = preconditioner;
  if (!preconditioner) return;  // preconditioner() is null until a preparation with it
  k_diagonal_blocks<<<frame_grid(n), kFrameThreads, 0, m.stream>>>(
      n, m.elasticity ? m.elasticity->diagonal_blocks_on_device() : nullptr, m.diag.data(), m.blocks.data());
  check();
  m.shells.add_diagonal_blocks(m.blocks.data(), m.stream);
  if (m.stabilised) m.stabilisation.add_diagonal_blocks(m.blocks.data(), m.stream);
  if (m.damped()) {
    if (!m.start_diagonal) m.start_elasticity->prepare_on_device(true);
    m.start_diagonal = true;
    m.ops.axpy(m.terms.beta / m.terms.h, m.start_elasticity->diagonal_blocks_on_device(), m.blocks.data(), 36LL * n);
  }
  m.mapping.reduce_diagonal_blocks(m.blocks.data(), m.stream);
  if (m.frame_blocks) m.ops.axpy(1.0, m.frame_blocks, m.blocks.data(), 36LL * n);
  k_block_jacobi<<<frame_grid(n), kFrameThreads, 0, m.stream>>>(n, m.blocks.data(), m.fixed.data(), m.minv.data());
  check();
}

void DevicePotential::apply(const double* d_reduced, double* out) {
  Impl& m = *m_impl;
  const int n = m_model.frame_count();
  const double* d = d_reduced;
  if (!m.mapping.empty()) {
    m.mapping.expand(d_reduced, m.expanded.data(), m.stream);
    d = m.expanded.data();
  }
  if (m.elasticity) {
    m.elasticity->apply_tangent_on_device(d, out, m.diag.data());  // with the frame terms
  } else {
    m.ops.fill(out, 0.0, dofs());
    k_add_frame_diagonal<<<frame_grid(n), kFrameThreads, 0, m.stream>>>(n, m.diag.data(), d, out);
    check();
  }
  m.shells.add_tangent(d, out, m.stream);
  if (m.stabilised) m.stabilisation.add_tangent(d, out, m.stream);
  if (m.damped()) {
    m.start_elasticity->apply_tangent_on_device(d, m.damped_product.data());
    m.ops.axpy(m.terms.beta / m.terms.h, m.damped_product.data(), out, dofs());
  }
  m.mapping.reduce_product(d_reduced, out, m.stream);
  if (m.frame_blocks) m.ops.block_apply(m.frame_blocks, d_reduced, out, n, true);
}

void DevicePotential::set_tangent_blocks(const std::vector<int>& block_offsets, const std::vector<int>& block_frames,
                                         const std::vector<int>& diagonal_blocks) {
  Impl& m = *m_impl;
  m.block_count = static_cast<long long>(block_frames.size());
  m.diagonal_blocks.upload(diagonal_blocks);
  if (m.elasticity) m.elasticity->set_tangent_blocks(block_offsets, block_frames, diagonal_blocks);
  m.shells.set_tangent_blocks(block_offsets, block_frames);
  m.stabilisation.set_tangent_blocks(block_offsets, block_frames);
  if (m.start_elasticity) {
    m.start_elasticity->set_tangent_blocks(block_offsets, block_frames, diagonal_blocks);
    m.start_blocks.resize(36 * block_frames.size());
    m.start_blocks_formed = false;
  }
}

void DevicePotential::tangent_blocks(double* blocks) {
  Impl& m = *m_impl;
  const int n = m_model.frame_count();
  if (m.elasticity)
    m.elasticity->tangent_blocks_on_device(blocks);
  else
    m.ops.fill(blocks, 0.0, 36 * m.block_count);
  m.shells.add_tangent_blocks(blocks, m.stream);
  if (m.stabilised) m.stabilisation.add_tangent_blocks(blocks, m.stream);
  if (m.damped()) {
    if (!m.start_blocks_formed) m.start_elasticity->tangent_blocks_on_device(m.start_blocks.data());
    m.start_blocks_formed = true;
    m.ops.axpy(m.terms.beta / m.terms.h, m.start_blocks.data(), blocks, 36 * m.block_count);
  }
  k_add_frame_blocks<<<frame_grid(n), kFrameThreads, 0, m.stream>>>(n, m.diagonal_blocks.data(), m.diag.data(), blocks);
  check();
  if (m.frame_blocks) {
    k_add_blocks<<<frame_grid(n), kFrameThreads, 0, m.stream>>>(n, m.diagonal_blocks.data(), m.frame_blocks, blocks);
    check();
  }
}

const double* DevicePotential::preconditioner() const {
  return m_impl->preconditioned ? m_impl->minv.data() : nullptr;
}

void DevicePotential::retract(DeviceFrames& q, const double* d, double scale) {
  Impl& m = *m_impl;
  const int n = m_model.frame_count();
  k_retract<<<frame_grid(n), kFrameThreads, 0, m.stream>>>(n, m_model.rotations_locked, d, scale, q.positions(),
                                                           q.orientations());
  check();
  m.mapping.sync(q.positions(), q.orientations(), m.stream);
}

}  // namespace fascia::gpu
