#include "mechanics/shell.hpp"

#include "core/double_lanes.hpp"
#include "core/rotation.hpp"
#include "core/target_clones.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace fascia {
namespace {

// A loop runs on the step's threads where its work exceeds about 0.25 ms; below that, a parallel
// region's start and barrier (tens of µs where the idle threads sleep, as under the passive wait
// policy on a VM: apps/fascia/wait_policy.cpp), and the delay of a core that is busy with another
// process in joining it, cost more than they save. Costs per item on one core (AVX2): a tangent
// product's block row 0.06 µs (7 blocks on a closed surface), a lane group's Hessian 1.9 µs, its
// gradient 0.65 µs, its energy 0.4 µs. On a 2-core VM, the pelvis's two shells (80 lane groups
// each, 10 per colour) running these loops on two threads made its step 45 % slower than on one.
constexpr double kParallelWorkUs = 250;
constexpr int kParallelTangentRows = static_cast<int>(kParallelWorkUs / 0.06);
constexpr int kParallelHessianGroups = static_cast<int>(kParallelWorkUs / 1.9);
constexpr int kParallelGradientGroups = static_cast<int>(kParallelWorkUs / 0.65);
constexpr int kParallelEnergyGroups = static_cast<int>(kParallelWorkUs / 0.4);

// Node positions and rotations of triangle e.
void load_element(const ShellElementRest& e, const State& state, Vec3 x[3], Mat3 R[3]) {
  for (int i = 0; i < 3; ++i) {
    const int node = e.nodes[i];
    x[i] = load3(&state.positions[3 * node]);
    R[i] = rotation_matrix(load_quat(&state.orientations[4 * node]));
  }
}

// Node positions and rotations of the kDoubleLanes triangles of one lane group, lane l holding
// triangle members[l] (-1: an empty lane, which repeats the group's first triangle).
FASCIA_CLONE_INLINE void load_lanes(const ShellElementRest* elements, const int* members, const State& state,
                                    Vec3T<DoubleLanes> x[3], Mat3T<DoubleLanes> R[3]) {
  for (int l = 0; l < kDoubleLanes; ++l) {
    Vec3 xl[3];
    Mat3 Rl[3];
    load_element(elements[members[l] >= 0 ? members[l] : members[0]], state, xl, Rl);
    for (int i = 0; i < 3; ++i) {
      x[i].x[l] = xl[i].x, x[i].y[l] = xl[i].y, x[i].z[l] = xl[i].z;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) R[i].m[r][c][l] = Rl[i].m[r][c];
    }
  }
}

// Adds the Hessians at the state of the triangles of one lane group (e, packed by lane_element)
// into their node blocks: triangle t's block (a, b) of its nodes is at blocks + 36
// element_blocks[9 t + 3 a + b] (column-major). The element functions run on DoubleLanes,
// inlined into a clone for AVX2 + FMA (core/target_clones.hpp): four triangles per instruction.
FASCIA_CLONES __attribute__((flatten)) void add_lane_hessians(const ShellElementRestT<DoubleLanes>& e,
                                                              const ShellElementRest* elements, const int* members,
                                                              const ShellModuli& moduli, const State& state,
                                                              const int* element_blocks, double* blocks) {
  Vec3T<DoubleLanes> x[3];
  Mat3T<DoubleLanes> R[3];
  load_lanes(elements, members, state, x, R);
  DoubleLanes g[kShellElementDofs], H[kShellElementDofs * kShellElementDofs];
  shell_element_hessian(e, moduli, x, R, g, H);
  for (int l = 0; l < kDoubleLanes; ++l) {
    if (members[l] < 0) continue;
    const int* node_blocks = element_blocks + 9 * members[l];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        double* B = blocks + 36 * static_cast<size_t>(node_blocks[3 * a + b]);
        // Column c of block (a, b) is row 6b + c of the symmetric H, from its column 6a.
        for (int c = 0; c < 6; ++c) {
          const DoubleLanes* h = &H[kShellElementDofs * (6 * b + c) + 6 * a];
          for (int r = 0; r < 6; ++r) B[6 * c + r] += h[r][l];
        }
      }
  }
}

// The gradients [T][18] and energies [T] (J) at the state of the triangles of one lane group, as
// add_lane_hessians.
FASCIA_CLONES __attribute__((flatten)) void lane_gradients(const ShellElementRestT<DoubleLanes>& e,
                                                           const ShellElementRest* elements, const int* members,
                                                           const ShellModuli& moduli, const State& state,
                                                           double* gradients, double* energies) {
  Vec3T<DoubleLanes> x[3];
  Mat3T<DoubleLanes> R[3];
  load_lanes(elements, members, state, x, R);
  DoubleLanes g[kShellElementDofs];
  const DoubleLanes w = shell_element_gradient(e, moduli, x, R, g);
  for (int l = 0; l < kDoubleLanes; ++l) {
    const int t = members[l];
    if (t < 0) continue;
    energies[t] = w[l];
    for (int k = 0; k < kShellElementDofs; ++k) gradients[kShellElementDofs * t + k] = g[k][l];
  }
}

// The energies [T] (J) at the state of the triangles of one lane group, as add_lane_hessians.
FASCIA_CLONES __attribute__((flatten)) void lane_energies(const ShellElementRestT<DoubleLanes>& e,
                                                          const ShellElementRest* elements, const int* members,
                                                          const ShellModuli& moduli, const State& state,
                                                          double* energies) {
  Vec3T<DoubleLanes> x[3];
  Mat3T<DoubleLanes> R[3];
  load_lanes(elements, members, state, x, R);
  const DoubleLanes w = shell_element_energy(e, moduli, x, R);
  for (int l = 0; l < kDoubleLanes; ++l)
    if (members[l] >= 0) energies[members[l]] = w[l];
}

// Triangles members[0 .. kDoubleLanes) packed lane by lane (an empty lane, -1, repeats the first).
ShellElementRestT<DoubleLanes> lane_element(const std::vector<ShellElementRest>& elements, const int* members) {
  ShellElementRestT<DoubleLanes> p;
  for (int i = 0; i < 3; ++i) p.nodes[i] = -1;  // the lanes' nodes are their triangles'
  for (int l = 0; l < kDoubleLanes; ++l) {
    const ShellElementRest& e = elements[members[l] >= 0 ? members[l] : members[0]];
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 2; ++c) p.dm_inverse[r][c][l] = e.dm_inverse[r][c];
    p.area[l] = e.area;
    for (int i = 0; i < 3; ++i) {
      p.axes[i].x[l] = e.axes[i].x, p.axes[i].y[l] = e.axes[i].y, p.axes[i].z[l] = e.axes[i].z;
      p.rest[i].x[l] = e.rest[i].x, p.rest[i].y[l] = e.rest[i].y, p.rest[i].z[l] = e.rest[i].z;
    }
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) p.bending[r][c][l] = e.bending[r][c];
  }
  return p;
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
    : m_shell(shell),
      m_moduli(make_shell_moduli(shell.young, shell.poisson, shell.thickness)),
      m_threads(threads > 0 ? threads : omp_get_max_threads()) {
  const int t_count = static_cast<int>(shell.triangles.size() / 3);
  m_elements.reserve(t_count);
  for (int t = 0; t < t_count; ++t)
    m_elements.push_back(make_shell_element(model.frame_rest_positions.data(), shell.triangles[3 * t],
                                            shell.triangles[3 * t + 1], shell.triangles[3 * t + 2], shell));
  build_block_structure();
  m_element_gradients.assign(static_cast<size_t>(t_count) * kShellElementDofs, 0.0);
  m_element_energies.assign(t_count, 0.0);
}

void ShellForceField::build_block_structure() {
  // Every (node a, node b) pair of every element, sorted by (row frame, column frame): equal frame
  // pairs become one block.
  struct Entry {
    int row, col;
    int element_block;  // 9 t + 3 a + b
  };
  std::vector<Entry> entries;
  entries.reserve(9 * m_elements.size());
  for (size_t t = 0; t < m_elements.size(); ++t)
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        entries.push_back({m_elements[t].nodes[a], m_elements[t].nodes[b], static_cast<int>(9 * t + 3 * a + b)});
  std::sort(entries.begin(), entries.end(), [](const Entry& x, const Entry& y) {
    return x.row != y.row ? x.row < y.row : x.col != y.col ? x.col < y.col : x.element_block < y.element_block;
  });
  m_row_frames.clear(), m_row_offsets.assign(1, 0), m_block_frames.clear(), m_diagonal_blocks.clear();
  m_element_blocks.assign(entries.size(), 0);
  for (size_t k = 0; k < entries.size(); ++k) {
    const Entry& x = entries[k];
    const bool new_row = k == 0 || x.row != entries[k - 1].row;
    const bool new_block = new_row || x.col != entries[k - 1].col;
    if (new_row) {
      if (k > 0) m_row_offsets.push_back(static_cast<int>(m_block_frames.size()));
      m_row_frames.push_back(x.row);
    }
    if (new_block) {
      if (x.col == x.row) m_diagonal_blocks.push_back(static_cast<int>(m_block_frames.size()));
      m_block_frames.push_back(x.col);
    }
    m_element_blocks[x.element_block] = static_cast<int>(m_block_frames.size()) - 1;
  }
  if (!entries.empty()) m_row_offsets.push_back(static_cast<int>(m_block_frames.size()));
  m_blocks.assign(36 * m_block_frames.size(), 0.0);

  // Greedy colouring: each triangle takes the smallest colour that no earlier triangle sharing
  // one of its nodes has.
  std::vector<std::vector<int>> node_colours;
  std::vector<int> colour(m_elements.size());
  int colours = 0;
  for (size_t t = 0; t < m_elements.size(); ++t) {
    std::vector<char> taken(colours + 1, 0);
    for (int node : m_elements[t].nodes) {
      if (node >= static_cast<int>(node_colours.size())) node_colours.resize(node + 1);
      for (int c : node_colours[node]) taken[c] = 1;
    }
    const int c = static_cast<int>(std::find(taken.begin(), taken.end(), 0) - taken.begin());
    colour[t] = c;
    colours = std::max(colours, c + 1);
    for (int node : m_elements[t].nodes) node_colours[node].push_back(c);
  }
  // Each colour's triangles in lane groups of kDoubleLanes, its last group padded with empty lanes.
  std::vector<int> count(colours, 0);
  for (int c : colour) ++count[c];
  m_colour_groups.assign(colours + 1, 0);
  for (int c = 0; c < colours; ++c) m_colour_groups[c + 1] = m_colour_groups[c] + (count[c] + kDoubleLanes - 1) / kDoubleLanes;
  m_group_members.assign(static_cast<size_t>(kDoubleLanes) * m_colour_groups[colours], -1);
  std::vector<int> next(colours);
  for (int c = 0; c < colours; ++c) next[c] = kDoubleLanes * m_colour_groups[c];
  for (size_t t = 0; t < m_elements.size(); ++t) m_group_members[next[colour[t]]++] = static_cast<int>(t);
  m_lane_elements.clear();
  for (int g = 0; g < m_colour_groups[colours]; ++g)
    m_lane_elements.push_back(lane_element(m_elements, &m_group_members[static_cast<size_t>(kDoubleLanes) * g]));
}

double ShellForceField::bending_stiffness() const {
  return m_shell.young * std::pow(m_shell.thickness, 3) / (12 * (1 - m_shell.poisson * m_shell.poisson));
}

double ShellForceField::energy(const State& state) {
  const int groups = static_cast<int>(m_lane_elements.size());
#pragma omp parallel for schedule(static) num_threads(m_threads) if (groups >= kParallelEnergyGroups)
  for (int g = 0; g < groups; ++g)
    lane_energies(m_lane_elements[g], m_elements.data(), &m_group_members[static_cast<size_t>(kDoubleLanes) * g],
                  m_moduli, state, m_element_energies.data());
  double w = 0;
  for (double v : m_element_energies) w += v;  // fixed order: independent of the thread count
  return w;
}

double ShellForceField::add_gradient(const State& state, double* gradient) {
  const int t_count = element_count();
  const int groups = static_cast<int>(m_lane_elements.size());
#pragma omp parallel for schedule(static) num_threads(m_threads) if (groups >= kParallelGradientGroups)
  for (int g = 0; g < groups; ++g)
    lane_gradients(m_lane_elements[g], m_elements.data(), &m_group_members[static_cast<size_t>(kDoubleLanes) * g],
                   m_moduli, state, m_element_gradients.data(), m_element_energies.data());
  double w = 0;
  for (int t = 0; t < t_count; ++t) {  // serial scatter: deterministic
    w += m_element_energies[t];
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 6; ++k)
        gradient[6 * m_elements[t].nodes[i] + k] += m_element_gradients[kShellElementDofs * t + 6 * i + k];
  }
  return w;
}

void ShellForceField::prepare(const State& state) {
  // Each element's Hessian is added into its nine node blocks (stored column-major: the
  // product's inner loop then runs over contiguous rows) as soon as it is formed. The triangles of
  // one colour share no node, so they write disjoint blocks in parallel, and every block sums its
  // elements in colour order, whatever the thread count.
  std::fill(m_blocks.begin(), m_blocks.end(), 0.0);
  for (size_t colour = 0; colour + 1 < m_colour_groups.size(); ++colour) {
    const int begin = m_colour_groups[colour], end = m_colour_groups[colour + 1];
#pragma omp parallel for schedule(static) num_threads(m_threads) if (end - begin >= kParallelHessianGroups)
    for (int g = begin; g < end; ++g)
      add_lane_hessians(m_lane_elements[g], m_elements.data(), &m_group_members[static_cast<size_t>(kDoubleLanes) * g],
                        m_moduli, state, m_element_blocks.data(), m_blocks.data());
  }
}

void ShellForceField::add_tangent(const double* d, double* out) const {
  const int rows = static_cast<int>(m_row_frames.size());
#pragma omp parallel for schedule(static) num_threads(m_threads) if (rows >= kParallelTangentRows)
  for (int row = 0; row < rows; ++row) {
    double acc[6] = {0, 0, 0, 0, 0, 0};
    for (int b = m_row_offsets[row]; b < m_row_offsets[row + 1]; ++b) {
      const double* B = &m_blocks[36 * static_cast<size_t>(b)];  // column-major
      const double* dj = d + 6 * m_block_frames[b];
      for (int c = 0; c < 6; ++c) {
        const double x = dj[c];
#pragma omp simd
        for (int r = 0; r < 6; ++r) acc[r] += B[6 * c + r] * x;
      }
    }
    double* oi = out + 6 * m_row_frames[row];
    for (int r = 0; r < 6; ++r) oi[r] += acc[r];
  }
}

void ShellForceField::add_diagonal_blocks(double* blocks) const {
  for (size_t row = 0; row < m_row_frames.size(); ++row) {
    const double* B = &m_blocks[36 * static_cast<size_t>(m_diagonal_blocks[row])];
    double* target = blocks + 36 * m_row_frames[row];
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) target[6 * r + c] += B[6 * c + r];
  }
}

void ShellForceField::add_triplets(std::vector<Eigen::Triplet<double>>& triplets) const {
  triplets.reserve(triplets.size() + m_blocks.size());
  for (size_t row = 0; row < m_row_frames.size(); ++row)
    for (int b = m_row_offsets[row]; b < m_row_offsets[row + 1]; ++b)
      for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c)
          triplets.emplace_back(6 * m_row_frames[row] + r, 6 * m_block_frames[b] + c, m_blocks[36 * static_cast<size_t>(b) + 6 * c + r]);
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
