#include "mechanics/shell.hpp"

#include "core/jet.hpp"
#include "core/rotation.hpp"

#include <omp.h>

#include <cmath>
#include <stdexcept>
#include <string>

namespace fascia {
namespace {

// Drilling penalty k_d = kDrillingFactor Y t A (see shell.hpp).
constexpr double kDrillingFactor = 1e-3;
constexpr int kElementDofs = 18;
using ElementJet = Jet<kElementDofs>;

// 3-vectors of a generic scalar (double or Jet) for the element energy.
template <class T>
struct V {
  T x, y, z;
};
template <class T>
V<T> vadd(const V<T>& a, const V<T>& b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
template <class T>
V<T> vsub(const V<T>& a, const V<T>& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <class T>
V<T> vscale(double s, const V<T>& a) {
  return {s * a.x, s * a.y, s * a.z};
}
template <class T>
V<T> vmul(const T& s, const V<T>& a) {
  return {s * a.x, s * a.y, s * a.z};
}
template <class T>
T vdot(const V<T>& a, const V<T>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <class T>
V<T> vcross(const V<T>& a, const V<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
// a x c with a constant c (scalar products only).
template <class T>
V<T> vcross(const V<T>& a, const Vec3& c) {
  return {c.z * a.y - c.y * a.z, c.x * a.z - c.z * a.x, c.y * a.x - c.x * a.y};
}

struct Moduli {
  double thickness, mu, lambda, young;
};

// W_e of shell.hpp. x: node positions; d[i][k] = R_i e_k (rest corotational axes turned by the
// node's rotation).
template <class T>
T element_energy(const ShellElementRest& e, const Moduli& m, const V<T> x[3], const V<T> d[3][3]) {
  using std::sqrt;
  const V<T> a = vsub(x[1], x[0]), b = vsub(x[2], x[0]);
  // Membrane in displacement form: U = [u1-u0, u2-u0] Dm^{-1}, E = sym(F0^T U) + U^T U / 2.
  V<T> u[3];
  for (int i = 0; i < 3; ++i) u[i] = {x[i].x - e.rest[i].x, x[i].y - e.rest[i].y, x[i].z - e.rest[i].z};
  const V<T> du1 = vsub(u[1], u[0]), du2 = vsub(u[2], u[0]);
  const V<T> U0 = vadd(vscale(e.dm_inverse[0][0], du1), vscale(e.dm_inverse[1][0], du2));
  const V<T> U1 = vadd(vscale(e.dm_inverse[0][1], du1), vscale(e.dm_inverse[1][1], du2));
  auto along = [](const Vec3& c, const V<T>& v) { return c.x * v.x + c.y * v.y + c.z * v.z; };
  const T e00 = along(e.axes[0], U0) + 0.5 * vdot(U0, U0);
  const T e11 = along(e.axes[1], U1) + 0.5 * vdot(U1, U1);
  const T e01 = 0.5 * (along(e.axes[0], U1) + along(e.axes[1], U0) + vdot(U0, U1));
  const T tr = e00 + e11;
  T w = (e.area * m.thickness) * (m.mu * (e00 * e00 + 2.0 * (e01 * e01) + e11 * e11) + (0.5 * m.lambda) * (tr * tr));
  // Corotational frame: e1 along x1 - x0, e3 normal.
  const V<T> n = vcross(a, b);
  const V<T> e3 = vmul(reciprocal(sqrt(vdot(n, n))), n);
  const V<T> e1 = vmul(reciprocal(sqrt(vdot(a, a))), a);
  const V<T> e2 = vcross(e3, e1);
  // Bending: nodal slopes beta_i = -(e1 . d_i3, e2 . d_i3), W_b = beta^T K_b beta / 2.
  T beta[6];
  for (int i = 0; i < 3; ++i) {
    beta[2 * i] = -vdot(e1, d[i][2]);
    beta[2 * i + 1] = -vdot(e2, d[i][2]);
  }
  for (int r = 0; r < 6; ++r) {
    T kb = e.bending[r][0] * beta[0];
    for (int c = 1; c < 6; ++c) kb = kb + e.bending[r][c] * beta[c];
    w = w + 0.5 * (kb * beta[r]);
  }
  // Drilling penalty.
  const double k_drill = kDrillingFactor * m.young * m.thickness * e.area;
  for (int i = 0; i < 3; ++i) {
    const T psi = 0.5 * (vdot(e2, d[i][0]) - vdot(e1, d[i][1]));
    w = w + (0.5 * k_drill) * (psi * psi);
  }
  return w;
}

double element_value(const ShellElementRest& e, const Moduli& m, const State& state) {
  V<double> x[3], d[3][3];
  for (int i = 0; i < 3; ++i) {
    const int node = e.nodes[i];
    const Vec3 p = load3(&state.positions[3 * node]);
    x[i] = {p.x, p.y, p.z};
    const Mat3 R = rotation_matrix(load_quat(&state.orientations[4 * node]));
    for (int k = 0; k < 3; ++k) {
      const Vec3 v = R * e.axes[k];
      d[i][k] = {v.x, v.y, v.z};
    }
  }
  return element_energy(e, m, x, d);
}

// The element energy as a jet in the 18 increments theta = [dx_0, dr_0, dx_1, ...] at theta = 0:
// x_i + dx_i and exp([dr_i]x) R_i, with exp to second order (exact for value, gradient and
// Hessian at theta = 0).
ElementJet element_jet(const ShellElementRest& e, const Moduli& m, const State& state) {
  V<ElementJet> x[3], d[3][3];
  for (int i = 0; i < 3; ++i) {
    const int node = e.nodes[i];
    const double* p = &state.positions[3 * node];
    x[i] = {ElementJet::variable(p[0], 6 * i), ElementJet::variable(p[1], 6 * i + 1),
            ElementJet::variable(p[2], 6 * i + 2)};
    const V<ElementJet> omega{ElementJet::variable(0, 6 * i + 3), ElementJet::variable(0, 6 * i + 4),
                              ElementJet::variable(0, 6 * i + 5)};
    const Mat3 R = rotation_matrix(load_quat(&state.orientations[4 * node]));
    for (int k = 0; k < 3; ++k) {
      const Vec3 a = R * e.axes[k];
      const V<ElementJet> wa = vcross(omega, a);
      const V<ElementJet> a_jet{ElementJet(a.x), ElementJet(a.y), ElementJet(a.z)};
      d[i][k] = vadd(vadd(a_jet, wa), vscale(0.5, vcross(omega, wa)));
    }
  }
  return element_energy(e, m, x, d);
}

}  // namespace

ShellElementRest make_shell_element(const double* rest_positions, int n0, int n1, int n2, const Shell& shell) {
  ShellElementRest e{};
  e.nodes[0] = n0, e.nodes[1] = n1, e.nodes[2] = n2;
  const Vec3 p0 = load3(rest_positions + 3 * n0), p1 = load3(rest_positions + 3 * n1),
             p2 = load3(rest_positions + 3 * n2);
  const Vec3 a = p1 - p0, b = p2 - p0, n = cross(a, b);
  e.area = 0.5 * norm(n);
  e.rest[0] = p0, e.rest[1] = p1, e.rest[2] = p2;
  if (!(e.area > 1e-12 * dot(a, a) + 1e-300) || !(norm(b) > 0))
    throw std::invalid_argument("shell: degenerate triangle at frames " + std::to_string(n0) + ", " +
                                std::to_string(n1) + ", " + std::to_string(n2));
  e.axes[0] = (1 / norm(a)) * a;
  e.axes[2] = (1 / norm(n)) * n;
  e.axes[1] = cross(e.axes[2], e.axes[0]);
  // Rest in-plane coordinates P_i.
  const double P[3][2] = {{0, 0}, {norm(a), 0}, {dot(b, e.axes[0]), dot(b, e.axes[1])}};
  const double Dm[2][2] = {{P[1][0], P[2][0]}, {P[1][1], P[2][1]}};
  const double det_dm = Dm[0][0] * Dm[1][1] - Dm[0][1] * Dm[1][0];  // = 2A > 0
  e.dm_inverse[0][0] = Dm[1][1] / det_dm, e.dm_inverse[0][1] = -Dm[0][1] / det_dm;
  e.dm_inverse[1][0] = -Dm[1][0] / det_dm, e.dm_inverse[1][1] = Dm[0][0] / det_dm;

  // DKT bending matrix. Barycentric gradients grad L_i = (y_j - y_k, x_k - x_j) / (2A).
  double gl[3][2];
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    gl[i][0] = (P[j][1] - P[k][1]) / det_dm;
    gl[i][1] = (P[k][0] - P[j][0]) / det_dm;
  }
  // Edge e joins (i, j) = (e+1, e+2); A_e = I/2 - 3/4 s s^T with s the unit edge tangent.
  double edge_matrix[3][2][2];
  for (int ed = 0; ed < 3; ++ed) {
    const int i = (ed + 1) % 3, j = (ed + 2) % 3;
    double s[2] = {P[j][0] - P[i][0], P[j][1] - P[i][1]};
    const double l = std::hypot(s[0], s[1]);
    s[0] /= l, s[1] /= l;
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 2; ++c) edge_matrix[ed][r][c] = (r == c ? 0.5 : 0.0) - 0.75 * s[r] * s[c];
  }
  const double D = shell.young * std::pow(shell.thickness, 3) / (12 * (1 - shell.poisson * shell.poisson));
  const double Db[3][3] = {{D, D * shell.poisson, 0}, {D * shell.poisson, D, 0}, {0, 0, D * (1 - shell.poisson) / 2}};
  for (auto& row : e.bending)
    for (double& v : row) v = 0;
  for (int q = 0; q < 3; ++q) {  // mid-edge points: L_q = 0, the other two 1/2
    double L[3] = {0.5, 0.5, 0.5};
    L[q] = 0;
    double B[3][6] = {};  // kappa = B beta
    for (int i = 0; i < 3; ++i) {
      // dG_i/dx_c (2x2) = dN_i/dx_c I + sum over edges e touching i of dN_e/dx_c A_e.
      double dG[2][2][2] = {};  // [c][row][col]
      for (int c = 0; c < 2; ++c) {
        const double dNi = (4 * L[i] - 1) * gl[i][c];
        dG[c][0][0] += dNi, dG[c][1][1] += dNi;
        for (int ed = 0; ed < 3; ++ed) {
          const int a0 = (ed + 1) % 3, a1 = (ed + 2) % 3;
          if (a0 != i && a1 != i) continue;
          const double dNe = 4 * (L[a0] * gl[a1][c] + L[a1] * gl[a0][c]);
          for (int r = 0; r < 2; ++r)
            for (int col = 0; col < 2; ++col) dG[c][r][col] += dNe * edge_matrix[ed][r][col];
        }
      }
      for (int col = 0; col < 2; ++col) {
        B[0][2 * i + col] = dG[0][0][col];
        B[1][2 * i + col] = dG[1][1][col];
        B[2][2 * i + col] = dG[1][0][col] + dG[0][1][col];
      }
    }
    const double weight = e.area / 3;
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) {
        double s = 0;
        for (int k = 0; k < 3; ++k)
          for (int l = 0; l < 3; ++l) s += B[k][r] * Db[k][l] * B[l][c];
        e.bending[r][c] += weight * s;
      }
  }
  return e;
}

ShellForceField::ShellForceField(const Model& model, const Shell& shell, int threads)
    : m_shell(shell), m_threads(threads > 0 ? threads : omp_get_max_threads()) {
  const double Y = shell.young, nu = shell.poisson;
  m_mu = Y / (2 * (1 + nu));
  m_lambda = Y * nu / (1 - nu * nu);
  const int t_count = static_cast<int>(shell.triangles.size() / 3);
  m_elements.reserve(t_count);
  for (int t = 0; t < t_count; ++t)
    m_elements.push_back(make_shell_element(model.frame_rest_positions.data(), shell.triangles[3 * t],
                                            shell.triangles[3 * t + 1], shell.triangles[3 * t + 2], shell));
  m_hessians.assign(static_cast<size_t>(t_count) * kElementDofs * kElementDofs, 0.0);
  m_element_gradients.assign(static_cast<size_t>(t_count) * kElementDofs, 0.0);
}

double ShellForceField::bending_stiffness() const {
  return m_shell.young * std::pow(m_shell.thickness, 3) / (12 * (1 - m_shell.poisson * m_shell.poisson));
}

double ShellForceField::energy(const State& state) {
  const Moduli m{m_shell.thickness, m_mu, m_lambda, m_shell.young};
  const int t_count = element_count();
  std::vector<double> values(t_count);
#pragma omp parallel for schedule(static) num_threads(m_threads)
  for (int t = 0; t < t_count; ++t) values[t] = element_value(m_elements[t], m, state);
  double w = 0;
  for (double v : values) w += v;  // fixed order: independent of the thread count
  return w;
}

double ShellForceField::add_gradient(const State& state, double* gradient) {
  const Moduli m{m_shell.thickness, m_mu, m_lambda, m_shell.young};
  const int t_count = element_count();
  std::vector<double> values(t_count);
#pragma omp parallel for schedule(dynamic, 16) num_threads(m_threads)
  for (int t = 0; t < t_count; ++t) {
    const ElementJet j = element_jet(m_elements[t], m, state);
    values[t] = j.v;
    for (int k = 0; k < kElementDofs; ++k) m_element_gradients[kElementDofs * t + k] = j.g[k];
  }
  double w = 0;
  for (int t = 0; t < t_count; ++t) {  // serial scatter: deterministic
    w += values[t];
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 6; ++k)
        gradient[6 * m_elements[t].nodes[i] + k] += m_element_gradients[kElementDofs * t + 6 * i + k];
  }
  return w;
}

void ShellForceField::prepare(const State& state) {
  const Moduli m{m_shell.thickness, m_mu, m_lambda, m_shell.young};
  const int t_count = element_count();
#pragma omp parallel for schedule(dynamic, 16) num_threads(m_threads)
  for (int t = 0; t < t_count; ++t) {
    const ElementJet j = element_jet(m_elements[t], m, state);
    double* H = &m_hessians[static_cast<size_t>(t) * kElementDofs * kElementDofs];
    for (int r = 0; r < kElementDofs; ++r)
      for (int c = 0; c < kElementDofs; ++c) H[kElementDofs * r + c] = 0.5 * (j.h[r][c] + j.h[c][r]);
  }
}

void ShellForceField::add_tangent(const double* d, double* out) const {
  for (int t = 0; t < element_count(); ++t) {
    const ShellElementRest& e = m_elements[t];
    const double* H = &m_hessians[static_cast<size_t>(t) * kElementDofs * kElementDofs];
    double de[kElementDofs];
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 6; ++k) de[6 * i + k] = d[6 * e.nodes[i] + k];
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 6; ++k) {
        const double* row = H + kElementDofs * (6 * i + k);
        double s = 0;
        for (int c = 0; c < kElementDofs; ++c) s += row[c] * de[c];
        out[6 * e.nodes[i] + k] += s;
      }
  }
}

void ShellForceField::add_diagonal_blocks(double* blocks) const {
  for (int t = 0; t < element_count(); ++t) {
    const ShellElementRest& e = m_elements[t];
    const double* H = &m_hessians[static_cast<size_t>(t) * kElementDofs * kElementDofs];
    for (int i = 0; i < 3; ++i)
      for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c) blocks[36 * e.nodes[i] + 6 * r + c] += H[kElementDofs * (6 * i + r) + 6 * i + c];
  }
}

void ShellForceField::add_triplets(std::vector<Eigen::Triplet<double>>& triplets) const {
  triplets.reserve(triplets.size() + m_hessians.size());
  for (int t = 0; t < element_count(); ++t) {
    const ShellElementRest& e = m_elements[t];
    const double* H = &m_hessians[static_cast<size_t>(t) * kElementDofs * kElementDofs];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        for (int r = 0; r < 6; ++r)
          for (int c = 0; c < 6; ++c)
            triplets.emplace_back(6 * e.nodes[a] + r, 6 * e.nodes[b] + c, H[kElementDofs * (6 * a + r) + 6 * b + c]);
  }
}

void add_shell_masses(Model& model, const Shell& shell) {
  const int n = model.frame_count();
  model.frame_masses.resize(n, 0.0);
  model.frame_inertias.resize(9 * n, 0.0);
  model.frame_point_masses.resize(n, 0.0);
  std::vector<double> mass(n, 0.0), area(n, 0.0);
  const double* X = model.frame_rest_positions.data();
  for (size_t t = 0; t + 2 < shell.triangles.size(); t += 3) {
    const int* v = &shell.triangles[t];
    const double A = 0.5 * norm(cross(load3(X + 3 * v[1]) - load3(X + 3 * v[0]), load3(X + 3 * v[2]) - load3(X + 3 * v[0])));
    for (int k = 0; k < 3; ++k) {
      mass[v[k]] += shell.density * shell.thickness * A / 3;
      area[v[k]] += A / 3;
    }
  }
  for (int i = 0; i < n; ++i) {
    if (mass[i] == 0) continue;
    model.frame_masses[i] += mass[i];
    model.frame_point_masses[i] += mass[i];
    for (int k = 0; k < 3; ++k) model.frame_inertias[9 * i + 4 * k] += mass[i] * area[i] / 6;
  }
}

}  // namespace fascia
