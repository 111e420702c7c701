#include "device_variational.hpp"

#include "device_buffers.cuh"
#include "integrate/discrete_action.hpp"

#include <algorithm>
#include <stdexcept>

namespace fascia::gpu {
namespace {

// One thread per frame in a grid that strides over the frames.
constexpr int kThreads = 128;
int grid(int n) { return std::max(1, std::min((n + kThreads - 1) / kThreads, 65535)); }

void check() { FASCIA_CUDA(cudaGetLastError()); }

// A step's two configurations, per frame: start (x0, q0) and end (x1, q1).
struct StepFrames {
  int n;
  bool locked;
  const double *x0, *q0, *x1, *q1;
  __device__ Vec3 start_x(int i) const { return load3(x0 + 3 * i); }
  __device__ Quat start_q(int i) const { return load_quat(q0 + 4 * i); }
  __device__ Vec3 end_x(int i) const { return load3(x1 + 3 * i); }
  __device__ Quat end_q(int i) const { return load_quat(q1 + 4 * i); }
};

__global__ void k_midpoint(StepFrames f, double* x, double* q) {
  for (int i = blockIdx.x * blockDim.x + threadIdx.x; i < f.n; i += gridDim.x * blockDim.x) {
    Vec3 xm;
    Quat qm;
    midpoint_frame(f.start_x(i), f.start_q(i), f.end_x(i), f.end_q(i), f.locked, xm, qm);
    store3(x + 3 * i, xm);
    store_quat(q + 4 * i, qm);
  }
}

__global__ void k_kinetic_momenta(StepFrames f, const double* masses, const double* inertias, double h, double* kappa) {
  for (int i = blockIdx.x * blockDim.x + threadIdx.x; i < f.n; i += gridDim.x * blockDim.x) {
    Vec3 px, pr;
    kinetic_momentum(masses[i], load_mat3(inertias + 9 * i), f.start_x(i), f.start_q(i), f.end_x(i), f.end_q(i), h,
                     f.locked, px, pr);
    store3(kappa + 6 * i, px);
    store3(kappa + 6 * i + 3, pr);
  }
}

// With sign = +1: r = (kappa + h B^T g - p) / h at the free DOFs (-D_1 S - p_k of (4) over h),
// zero at the fixed ones. With sign = -1 and p null: r = kappa - h A^T g (D_2 S of (5)).
// r holds the reduced kappa on entry; g is the reduced gradient of V at the midpoint.
__global__ void k_combine(StepFrames f, const double* g, double h, int sign, const double* p,
                          const std::uint8_t* fixed, double* r) {
  for (int i = blockIdx.x * blockDim.x + threadIdx.x; i < f.n; i += gridDim.x * blockDim.x) {
    Vec3 at, bt;
    midpoint_transposes(f.start_q(i), f.end_q(i), f.locked, load3(g + 6 * i + 3), at, bt);  // (3)
    const Vec3 gx = 0.5 * load3(g + 6 * i);
    const Vec3 tx = sign > 0 ? gx : -1.0 * gx;
    const Vec3 tr = sign > 0 ? bt : -1.0 * at;
    const double t[6] = {tx.x, tx.y, tx.z, tr.x, tr.y, tr.z};
    for (int k = 0; k < 6; ++k) {
      double v = r[6 * i + k] + h * t[k];
      if (p) v = fixed[6 * i + k] ? 0.0 : (v - p[6 * i + k]) / h;
      r[6 * i + k] = v;
    }
  }
}

__global__ void k_kinetic_blocks(StepFrames f, const double* masses, const double* inertias, double c, double* blocks) {
  for (int i = blockIdx.x * blockDim.x + threadIdx.x; i < f.n; i += gridDim.x * blockDim.x)
    kinetic_block(masses[i], load_mat3(inertias + 9 * i), f.start_q(i), f.end_q(i), c, f.locked, blocks + 36 * i);
}

}  // namespace

DeviceVariational::DeviceVariational(DevicePotential& potential, double dt)
    : m_potential(potential),
      m_dt(dt),
      m_start_mapping(potential.model()),
      m_end_mapping(potential.model()),
      m_start(potential.make_state()),
      m_mid(potential.make_state()) {
  if (!(dt > 0)) throw std::invalid_argument("variational step: time step must be > 0 s");
  const Model& model = potential.model();
  const size_t n = static_cast<size_t>(model.frame_count());
  std::vector<double> masses = model.frame_masses, inertias = model.frame_inertias;
  masses.resize(n, 0.0);
  inertias.resize(9 * n, 0.0);
  m_masses.upload(masses);
  m_inertias.upload(inertias);
  m_p_start.resize(6 * n);
  m_g.resize(6 * n);
  m_d2.resize(6 * n);
  m_kinetic_blocks.resize(36 * n);
}

void DeviceVariational::set_start(const State& start, const std::vector<double>& p_start) {
  m_start.upload(start);
  if (!p_start.empty()) m_p_start.upload(p_start);
  m_start_mapping.set_state(m_start.positions(), m_potential.ops().stream());
}

const DeviceFrames& DeviceVariational::midpoint(const DeviceFrames& end) {
  const Model& model = m_potential.model();
  const int n = model.frame_count();
  const cudaStream_t stream = m_potential.ops().stream();
  const StepFrames f{n, model.rotations_locked, m_start.positions(), m_start.orientations(), end.positions(),
                     end.orientations()};
  k_midpoint<<<grid(n), kThreads, 0, stream>>>(f, m_mid.positions(), m_mid.orientations());
  check();
  m_end_mapping.sync(m_mid.positions(), m_mid.orientations(), stream);
  return m_mid;
}

void DeviceVariational::kinetic_momenta(const DeviceFrames& end, const DeviceRigidMapping& mapping, double* out) {
  const Model& model = m_potential.model();
  const int n = model.frame_count();
  const cudaStream_t stream = m_potential.ops().stream();
  const StepFrames f{n, model.rotations_locked, m_start.positions(), m_start.orientations(), end.positions(),
                     end.orientations()};
  k_kinetic_momenta<<<grid(n), kThreads, 0, stream>>>(f, m_masses.data(), m_inertias.data(), m_dt, out);
  check();
  mapping.reduce(out, stream);
}

double DeviceVariational::residual(const DeviceFrames& end, double* r) {
  const Model& model = m_potential.model();
  const int n = model.frame_count();
  const double v = m_potential.gradient(midpoint(end), m_g.data());
  kinetic_momenta(end, m_start_mapping, r);
  const StepFrames f{n, model.rotations_locked, m_start.positions(), m_start.orientations(), end.positions(),
                     end.orientations()};
  k_combine<<<grid(n), kThreads, 0, m_potential.ops().stream()>>>(f, m_g.data(), m_dt, 1, m_p_start.data(),
                                                                   m_potential.fixed(), r);
  check();
  return v;
}

void DeviceVariational::set_kinetic_blocks(const DeviceFrames& end) {
  const Model& model = m_potential.model();
  const int n = model.frame_count();
  const cudaStream_t stream = m_potential.ops().stream();
  const StepFrames f{n, model.rotations_locked, m_start.positions(), m_start.orientations(), end.positions(),
                     end.orientations()};
  k_kinetic_blocks<<<grid(n), kThreads, 0, stream>>>(f, m_masses.data(), m_inertias.data(), 4 / (m_dt * m_dt),
                                                     m_kinetic_blocks.data());
  check();
  // J^T M_kin J per body (no geometric term: this mapping carries no forces).
  m_end_mapping.set_state(end.positions(), stream);
  m_end_mapping.reduce_diagonal_blocks(m_kinetic_blocks.data(), stream);
  m_potential.set_frame_blocks(m_kinetic_blocks.data());
}

void DeviceVariational::end_momenta(const DeviceFrames& end, std::vector<double>& p_end) {
  const Model& model = m_potential.model();
  const int n = model.frame_count();
  const VectorOps& ops = m_potential.ops();
  // D_2 S: the kinetic momenta reduced at end, less h A^T g with g at the midpoint.
  m_potential.gradient(midpoint(end), m_g.data());
  m_end_mapping.set_state(end.positions(), ops.stream());
  kinetic_momenta(end, m_end_mapping, m_d2.data());
  const StepFrames f{n, model.rotations_locked, m_start.positions(), m_start.orientations(), end.positions(),
                     end.orientations()};
  k_combine<<<grid(n), kThreads, 0, ops.stream()>>>(f, m_g.data(), m_dt, -1, nullptr, nullptr, m_d2.data());
  check();
  FASCIA_CUDA(cudaStreamSynchronize(ops.stream()));
  p_end.resize(6 * static_cast<size_t>(n));
  m_d2.download(p_end.data());
}

}  // namespace fascia::gpu
