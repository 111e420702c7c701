#include "model/model.hpp"

#include "core/small_math.hpp"

#include <algorithm>
#include <stdexcept>

namespace fascia {

int Model::max_neighbours() const {
  int n = 0;
  for (int s = 0; s < sample_count(); ++s)
    n = std::max(n, neighbours.offsets[s + 1] - neighbours.offsets[s]);
  return n;
}

double Model::total_volume() const {
  double v = 0;
  for (double x : samples.volumes) v += x;
  return v;
}

double Model::total_mass() const {
  double m = 0;
  for (double x : frame_masses) m += x;
  return m;
}

void build_reverse_table(Model& model) {
  const int n = model.frame_count();
  const int p_count = model.pair_count();
  ReverseTable& rev = model.reverse;
  rev.offsets.assign(n + 1, 0);
  for (int p = 0; p < p_count; ++p) ++rev.offsets[model.neighbours.frames[p] + 1];
  for (int i = 0; i < n; ++i) rev.offsets[i + 1] += rev.offsets[i];
  rev.pairs.assign(p_count, 0);
  std::vector<int> cursor(rev.offsets.begin(), rev.offsets.end() - 1);
  rev.pair_samples.assign(p_count, 0);
  for (int s = 0; s < model.sample_count(); ++s)
    for (int p = model.neighbours.offsets[s]; p < model.neighbours.offsets[s + 1]; ++p) rev.pair_samples[p] = s;
  for (int p = 0; p < p_count; ++p) rev.pairs[cursor[model.neighbours.frames[p]]++] = p;
}

void compute_frame_inertia(Model& model) {
  const int n = model.frame_count();
  model.frame_masses.assign(n, 0.0);
  model.frame_inertias.assign(9 * n, 0.0);
  std::vector<double> positive_masses(n, 0.0);
  const NeighbourTable& nb = model.neighbours;
  for (int s = 0; s < model.sample_count(); ++s) {
    const double rho = model.materials[model.samples.materials[s]].density;
    const double m_s = rho * model.samples.volumes[s];
    // The shares' normaliser: 1 (the weights themselves) unless a weight is negative.
    double positive = 0;
    bool negative = false;
    for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) {
      positive += std::max(nb.weights[p], 0.0);
      negative = negative || nb.weights[p] < 0;
    }
    if (!negative) positive = 1;
    for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) {
      const int i = nb.frames[p];
      model.frame_masses[i] += nb.weights[p] * m_s;
      if (!(nb.weights[p] > 0)) continue;
      // Point mass m at offset l from the frame origin: I = m (|l|^2 I - l l^T).
      const double m = nb.weights[p] / positive * m_s;
      positive_masses[i] += m;
      const Vec3 l = load3(&nb.rest_offsets[3 * p]);
      const Mat3 inertia = m * (dot(l, l) * identity3() - outer(l, l));
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) model.frame_inertias[9 * i + 3 * r + c] += inertia.m[r][c];
    }
  }
  for (int i = 0; i < n; ++i)
    if (!(model.frame_masses[i] > 0)) model.frame_masses[i] = positive_masses[i];
}

const char* to_string(ObjectKind kind) {
  switch (kind) {
    case ObjectKind::tissue: return "tissue";
    case ObjectKind::shell: return "shell";
    case ObjectKind::rigid: return "rigid";
  }
  return "?";
}

void lock_rotations(Model& model) {
  model.rotations_locked = true;
  model.samples.rotation_stabilised.clear();  // R_i = I: no frame rotation to stabilise
  model.fixed_dofs.resize(model.dof_count(), 0);
  for (int i = 0; i < model.frame_count(); ++i)
    for (int k = 3; k < 6; ++k) model.fixed_dofs[kFrameDofs * i + k] = 1;
}

void validate(const Model& model) {
  const int n = model.frame_count();
  const int s_count = model.sample_count();
  const int p_count = model.pair_count();
  const NeighbourTable& nb = model.neighbours;
  auto fail = [](const std::string& what) { throw std::invalid_argument("model: " + what); };
  if (model.samples.rest_positions.size() != 3u * s_count) fail("sample positions size");
  if (model.samples.materials.size() != static_cast<size_t>(s_count)) fail("sample materials size");
  if (!model.samples.rotation_stabilised.empty() && model.samples.rotation_stabilised.size() != static_cast<size_t>(s_count))
    fail("sample rotation_stabilised size");
  if (nb.offsets.size() != static_cast<size_t>(s_count) + 1 || nb.offsets.front() != 0 ||
      nb.offsets.back() != p_count)
    fail("neighbour offsets");
  if (nb.weights.size() != static_cast<size_t>(p_count) || nb.weight_gradients.size() != 3u * p_count ||
      nb.rest_offsets.size() != 3u * p_count)
    fail("neighbour table sizes");
  for (int p = 0; p < p_count; ++p)
    if (nb.frames[p] < 0 || nb.frames[p] >= n) fail("neighbour frame index out of range");
  for (int s = 0; s < s_count; ++s) {
    if (!(model.samples.volumes[s] > 0)) fail("sample " + std::to_string(s) + " has no volume");
    if (nb.offsets[s + 1] <= nb.offsets[s]) fail("sample " + std::to_string(s) + " has no neighbour");
    const int mat = model.samples.materials[s];
    if (mat < 0 || mat >= static_cast<int>(model.materials.size())) fail("sample material index");
  }
  if (model.reverse.offsets.size() != static_cast<size_t>(n) + 1 ||
      model.reverse.pairs.size() != static_cast<size_t>(p_count))
    fail("reverse table not built");
  if (model.fixed_dofs.size() != static_cast<size_t>(model.dof_count())) fail("fixed_dofs size");
  if (!model.frame_point_masses.empty() && model.frame_point_masses.size() != static_cast<size_t>(n))
    fail("frame_point_masses size");
  if (!model.rigid_parents.empty()) {
    if (model.rigid_parents.size() != static_cast<size_t>(n)) fail("rigid_parents size");
    for (int i = 0; i < n; ++i) {
      const int b = model.rigid_parents[i];
      if (b < -1 || b >= n || b == i) fail("rigid parent of frame " + std::to_string(i) + " out of range");
      if (b >= 0 && model.rigid_parents[b] >= 0) fail("rigid parent of frame " + std::to_string(i) + " is itself mapped");
    }
  }
  for (const Shell& shell : model.shells) {
    if (!(shell.thickness > 0) || !(shell.young > 0) || !(shell.poisson > -1 && shell.poisson < 0.5))
      fail("shell thickness, Young's modulus or Poisson's ratio out of range");
    for (int v : shell.triangles)
      if (v < 0 || v >= n) fail("shell vertex frame index out of range");
  }
}

}  // namespace fascia
