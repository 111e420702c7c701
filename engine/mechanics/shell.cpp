#include "mechanics/shell.hpp"

#include "core/rotation.hpp"
#include "core/target_clones.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace fascia {
namespace {

// A tangent product costs about 0.06 us per block row (7 blocks on a closed surface, SSE2): below
// this many rows (~0.25 ms) a parallel region's start and barrier, and the delay of a core that
// is busy with another process in joining it, cost more than they save.
constexpr int kParallelTangentRows = 4096;

// Node positions and rotations of triangle e.
void load_element(const ShellElementRest& e, const State& state, Vec3 x[3], Mat3 R[3]) {
  for (int i = 0; i < 3; ++i) {
    const int node = e.nodes[i];
    x[i] = load3(&state.positions[3 * node]);
    R[i] = rotation_matrix(load_quat(&state.orientations[4 * node]));
  }
}

// Adds triangle e's Hessian at the state into its nine node blocks, block (a, b) of its nodes at
// blocks + 36 node_blocks[3 a + b] (column-major), with the element functions inlined into a
// clone for AVX2 + FMA (core/target_clones.hpp).
FASCIA_CLONES __attribute__((flatten)) void add_element_hessian(const ShellElementRest& e, const ShellModuli& moduli,
                                                                const State& state, const int* node_blocks,
                                                                double* blocks) {
  Vec3 x[3];
  Mat3 R[3];
  load_element(e, state, x, R);
  double g[kShellElementDofs], H[kShellElementDofs * kShellElementDofs];
  shell_element_hessian(e, moduli, x, R, g, H);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      double* B = blocks + 36 * static_cast<size_t>(node_blocks[3 * a + b]);
      // Column c of block (a, b) is row 6b + c of the symmetric H, from its column 6a.
      for (int c = 0; c < 6; ++c) {
        const double* h = &H[kShellElementDofs * (6 * b + c) + 6 * a];
#pragma omp simd
        for (int r = 0; r < 6; ++r) B[6 * c + r] += h[r];
      }
    }
}

// Triangle e's gradient g[18] at the state, inlined into clones as add_element_hessian. Returns
// its energy, J.
FASCIA_CLONES __attribute__((flatten)) double element_gradient(const ShellElementRest& e, const ShellModuli& moduli,
                                                               const State& state, double* g) {
  Vec3 x[3];
  Mat3 R[3];
  load_element(e, state, x, R);
  return shell_element_gradient(e, moduli, x, R, g);
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
  m_colour_offsets.assign(colours + 1, 0);
  for (int c : colour) ++m_colour_offsets[c + 1];
  for (int c = 0; c < colours; ++c) m_colour_offsets[c + 1] += m_colour_offsets[c];
  m_colour_elements.resize(m_elements.size());
  std::vector<int> next(m_colour_offsets.begin(), m_colour_offsets.end() - 1);
  for (size_t t = 0; t < m_elements.size(); ++t) m_colour_elements[next[colour[t]]++] = static_cast<int>(t);
}

double ShellForceField::bending_stiffness() const {
  return m_shell.young * std::pow(m_shell.thickness, 3) / (12 * (1 - m_shell.poisson * m_shell.poisson));
}

double ShellForceField::energy(const State& state) {
  const int t_count = element_count();
#pragma omp parallel for schedule(static) num_threads(m_threads)
  for (int t = 0; t < t_count; ++t) {
    Vec3 x[3];
    Mat3 R[3];
    load_element(m_elements[t], state, x, R);
    m_element_energies[t] = shell_element_energy(m_elements[t], m_moduli, x, R);
  }
  double w = 0;
  for (double v : m_element_energies) w += v;  // fixed order: independent of the thread count
  return w;
}

double ShellForceField::add_gradient(const State& state, double* gradient) {
  const int t_count = element_count();
#pragma omp parallel for schedule(static) num_threads(m_threads)
  for (int t = 0; t < t_count; ++t)
    m_element_energies[t] =
        element_gradient(m_elements[t], m_moduli, state, &m_element_gradients[kShellElementDofs * t]);
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
  for (size_t colour = 0; colour + 1 < m_colour_offsets.size(); ++colour) {
    const int begin = m_colour_offsets[colour], end = m_colour_offsets[colour + 1];
#pragma omp parallel for schedule(static) num_threads(m_threads)
    for (int k = begin; k < end; ++k) {
      const int t = m_colour_elements[k];
      add_element_hessian(m_elements[t], m_moduli, state, &m_element_blocks[9 * t], m_blocks.data());
    }
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
