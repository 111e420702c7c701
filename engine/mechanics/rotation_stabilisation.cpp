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

Mat3 frame_rotation(const State& state, int i) { return rotation_matrix(load_quat(&state.orientations[4 * i])); }

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
        it = index.emplace(key, static_cast<int>(m_edges.size())).first;
        const Vec3 d = load3(&model.frame_rest_positions[3 * key.second]) - load3(&model.frame_rest_positions[3 * key.first]);
        m_edges.push_back(EdgeTwist{{key.first, key.second}, (1.0 / norm(d)) * d, 0.0});
      }
      m_edges[it->second].stiffness += k;
    }
  }
  m_hessians.assign(36 * m_edges.size(), 0.0);
}

double RotationStabilisation::energy(const State& state) {
  double w = 0;
  for (const EdgeTwist& e : m_edges)
    w += edge_twist_energy(e, frame_rotation(state, e.nodes[0]), frame_rotation(state, e.nodes[1]));
  return w;
}

double RotationStabilisation::add_gradient(const State& state, double* gradient) {
  double w = 0;
  for (const EdgeTwist& e : m_edges) {
    const EdgeTwistTerm t =
        edge_twist_term(e, frame_rotation(state, e.nodes[0]), frame_rotation(state, e.nodes[1]), false);
    w += t.energy;
    for (int a = 0; a < 3; ++a) {
      gradient[6 * e.nodes[0] + 3 + a] += t.gradient[a];
      gradient[6 * e.nodes[1] + 3 + a] += t.gradient[3 + a];
    }
  }
  return w;
}

void RotationStabilisation::prepare(const State& state) {
  for (int k = 0; k < edge_count(); ++k) {
    const EdgeTwist& e = m_edges[k];
    const EdgeTwistTerm t =
        edge_twist_term(e, frame_rotation(state, e.nodes[0]), frame_rotation(state, e.nodes[1]), true);
    for (int a = 0; a < 6; ++a)
      for (int b = 0; b < 6; ++b) m_hessians[36 * static_cast<size_t>(k) + 6 * a + b] = t.hessian[a][b];
  }
}

void RotationStabilisation::add_tangent(const double* d, double* out) const {
  for (int e = 0; e < edge_count(); ++e) {
    const int* frame = m_edges[e].nodes;
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
      double* B = blocks + 36 * static_cast<size_t>(m_edges[e].nodes[end]);
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) B[6 * (3 + a) + 3 + b] += H[6 * (3 * end + a) + 3 * end + b];
    }
  }
}

void RotationStabilisation::add_triplets(std::vector<Eigen::Triplet<double>>& triplets) const {
  triplets.reserve(triplets.size() + 36 * m_edges.size());
  for (int e = 0; e < edge_count(); ++e) {
    const int* frame = m_edges[e].nodes;
    const double* H = &m_hessians[36 * static_cast<size_t>(e)];
    for (int a = 0; a < 6; ++a)
      for (int b = 0; b < 6; ++b)
        triplets.emplace_back(6 * frame[a / 3] + 3 + a % 3, 6 * frame[b / 3] + 3 + b % 3, H[6 * a + b]);
  }
}

}  // namespace fascia
