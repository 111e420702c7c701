#include "mechanics/rotation_stabilisation.hpp"

#include "core/rotation.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

namespace fascia {
namespace {

// The 12 edges of a hexahedron in VTK corner order.
constexpr int kHexEdges[12][2] = {{0, 1}, {1, 2}, {3, 2}, {0, 3}, {4, 5}, {5, 6},
                                  {7, 6}, {4, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

// The rotation increments of unit vector k of the edge's 6 rotational DOFs (dr_i, dr_j).
Vec3 unit(int k, int which) {
  if (k / 3 != which) return Vec3{0, 0, 0};
  return Vec3{k % 3 == 0 ? 1.0 : 0.0, k % 3 == 1 ? 1.0 : 0.0, k % 3 == 2 ? 1.0 : 0.0};
}

struct EdgeTerm {
  double energy;
  double gradient[6];     // dE / d(dr_i, dr_j)
  double hessian[6][6];
};

// E = k/8 tau^2, tau = e . axial(R_i^T R_j), and its derivatives (header).
EdgeTerm edge_term(const Mat3& Ri, const Mat3& Rj, const Vec3& e, double k) {
  const Mat3 Rit = transpose(Ri);
  const double tau = dot(e, axial(Rit * Rj));
  EdgeTerm t{};
  t.energy = 0.125 * k * tau * tau;
  double dtau[6];
  for (int a = 0; a < 6; ++a) dtau[a] = dot(e, axial(Rit * skew(unit(a, 1) - unit(a, 0)) * Rj));
  for (int a = 0; a < 6; ++a) t.gradient[a] = 0.25 * k * tau * dtau[a];
  for (int a = 0; a < 6; ++a)
    for (int b = a; b < 6; ++b) {
      const Mat3 ai = skew(unit(a, 0)), aj = skew(unit(a, 1)), bi = skew(unit(b, 0)), bj = skew(unit(b, 1));
      const Mat3 second = 0.5 * (ai * bi + bi * ai) - ai * bj - bi * aj + 0.5 * (aj * bj + bj * aj);
      const double d2tau = dot(e, axial(Rit * second * Rj));
      t.hessian[a][b] = t.hessian[b][a] = 0.25 * k * (dtau[a] * dtau[b] + tau * d2tau);
    }
  return t;
}

}  // namespace

bool RotationStabilisation::applies(const Model& model) {
  if (model.rotations_locked) return false;
  return std::any_of(model.samples.rotation_stabilised.begin(), model.samples.rotation_stabilised.end(),
                     [](std::uint8_t f) { return f != 0; });
}

RotationStabilisation::RotationStabilisation(const Model& model, int, double kappa) {
  if (!applies(model)) return;
  const NeighbourTable& nb = model.neighbours;
  std::map<std::pair<int, int>, int> index;
  for (int s = 0; s < model.sample_count(); ++s) {
    if (!model.samples.rotation_stabilised[s] || nb.offsets[s + 1] - nb.offsets[s] != 8) continue;
    const int* corner = &nb.frames[nb.offsets[s]];
    const double k = kappa * model.materials[model.samples.materials[s]].mu * model.samples.volumes[s] / 12;
    for (const auto& edge : kHexEdges) {
      const int i = corner[edge[0]], j = corner[edge[1]];
      if (i == j) continue;
      const auto key = std::make_pair(std::min(i, j), std::max(i, j));
      auto it = index.find(key);
      if (it == index.end()) {
        it = index.emplace(key, static_cast<int>(m_stiffness.size())).first;
        m_edges.insert(m_edges.end(), {key.first, key.second});
        const Vec3 d = load3(&model.frame_rest_positions[3 * key.second]) - load3(&model.frame_rest_positions[3 * key.first]);
        const Vec3 e = (1.0 / norm(d)) * d;
        m_directions.insert(m_directions.end(), {e.x, e.y, e.z});
        m_stiffness.push_back(0.0);
      }
      m_stiffness[it->second] += k;
    }
  }
  m_hessians.assign(36 * m_stiffness.size(), 0.0);
}

double RotationStabilisation::energy(const State& state) {
  double w = 0;
  for (int e = 0; e < edge_count(); ++e) {
    const Mat3 Ri = rotation_matrix(load_quat(&state.orientations[4 * m_edges[2 * e]]));
    const Mat3 Rj = rotation_matrix(load_quat(&state.orientations[4 * m_edges[2 * e + 1]]));
    const double tau = dot(load3(&m_directions[3 * e]), axial(transpose(Ri) * Rj));
    w += 0.125 * m_stiffness[e] * tau * tau;
  }
  return w;
}

double RotationStabilisation::add_gradient(const State& state, double* gradient) {
  double w = 0;
  for (int e = 0; e < edge_count(); ++e) {
    const int i = m_edges[2 * e], j = m_edges[2 * e + 1];
    const EdgeTerm t = edge_term(rotation_matrix(load_quat(&state.orientations[4 * i])),
                                 rotation_matrix(load_quat(&state.orientations[4 * j])), load3(&m_directions[3 * e]),
                                 m_stiffness[e]);
    w += t.energy;
    for (int a = 0; a < 3; ++a) {
      gradient[6 * i + 3 + a] += t.gradient[a];
      gradient[6 * j + 3 + a] += t.gradient[3 + a];
    }
  }
  return w;
}

void RotationStabilisation::prepare(const State& state) {
  for (int e = 0; e < edge_count(); ++e) {
    const int i = m_edges[2 * e], j = m_edges[2 * e + 1];
    const EdgeTerm t = edge_term(rotation_matrix(load_quat(&state.orientations[4 * i])),
                                 rotation_matrix(load_quat(&state.orientations[4 * j])), load3(&m_directions[3 * e]),
                                 m_stiffness[e]);
    for (int a = 0; a < 6; ++a)
      for (int b = 0; b < 6; ++b) m_hessians[36 * static_cast<size_t>(e) + 6 * a + b] = t.hessian[a][b];
  }
}

void RotationStabilisation::add_tangent(const double* d, double* out) const {
  for (int e = 0; e < edge_count(); ++e) {
    const int frame[2] = {m_edges[2 * e], m_edges[2 * e + 1]};
    const double* H = &m_hessians[36 * static_cast<size_t>(e)];
    for (int a = 0; a < 6; ++a) {
      double acc = 0;
      for (int b = 0; b < 6; ++b) acc += H[6 * a + b] * d[6 * frame[b / 3] + 3 + b % 3];
      out[6 * frame[a / 3] + 3 + a % 3] += acc;
    }
  }
}

void RotationStabilisation::add_diagonal_blocks(double* blocks) const {
  for (int e = 0; e < edge_count(); ++e) {
    const double* H = &m_hessians[36 * static_cast<size_t>(e)];
    for (int end = 0; end < 2; ++end) {
      double* B = blocks + 36 * static_cast<size_t>(m_edges[2 * e + end]);
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) B[6 * (3 + a) + 3 + b] += H[6 * (3 * end + a) + 3 * end + b];
    }
  }
}

void RotationStabilisation::add_triplets(std::vector<Eigen::Triplet<double>>& triplets) const {
  triplets.reserve(triplets.size() + 36 * m_stiffness.size());
  for (int e = 0; e < edge_count(); ++e) {
    const double* H = &m_hessians[36 * static_cast<size_t>(e)];
    for (int a = 0; a < 6; ++a)
      for (int b = 0; b < 6; ++b)
        triplets.emplace_back(6 * m_edges[2 * e + a / 3] + 3 + a % 3, 6 * m_edges[2 * e + b / 3] + 3 + b % 3, H[6 * a + b]);
  }
}

}  // namespace fascia
