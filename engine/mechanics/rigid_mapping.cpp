#include "mechanics/rigid_mapping.hpp"

#include "core/rotation.hpp"

namespace fascia {

RigidMapping::RigidMapping(const Model& model) {
  for (int a = 0; a < static_cast<int>(model.rigid_parents.size()); ++a) {
    const int b = model.rigid_parents[a];
    if (b < 0) continue;
    m_mapped.push_back(a);
    m_bodies.push_back(b);
    const Vec3 c = load3(&model.frame_rest_positions[3 * a]) - load3(&model.frame_rest_positions[3 * b]);
    m_rest_offsets.insert(m_rest_offsets.end(), {c.x, c.y, c.z});
  }
  m_offsets = m_rest_offsets;
  m_forces.assign(m_rest_offsets.size(), 0.0);
}

void RigidMapping::sync(State& state) const {
  for (size_t k = 0; k < m_mapped.size(); ++k) {
    const int a = m_mapped[k], b = m_bodies[k];
    const Mat3 R = rotation_matrix(load_quat(&state.orientations[4 * b]));
    store3(&state.positions[3 * a], load3(&state.positions[3 * b]) + R * load3(&m_rest_offsets[3 * k]));
    for (int c = 0; c < 4; ++c) state.orientations[4 * a + c] = state.orientations[4 * b + c];
  }
}

void RigidMapping::set_state(const State& state) {
  for (size_t k = 0; k < m_mapped.size(); ++k)
    store3(&m_offsets[3 * k], load3(&state.positions[3 * m_mapped[k]]) - load3(&state.positions[3 * m_bodies[k]]));
}

void RigidMapping::reduce(double* v) const {
  for (size_t k = 0; k < m_mapped.size(); ++k) {
    double* va = v + 6 * m_mapped[k];
    double* vb = v + 6 * m_bodies[k];
    const Vec3 f = load3(va), r = load3(&m_offsets[3 * k]);
    // J^T [f; t] = [f; t + r x f]  (since (-[r]x)^T f = r x f)
    const Vec3 t = cross(r, f);
    for (int c = 0; c < 3; ++c) vb[c] += va[c];
    vb[3] += va[3] + t.x, vb[4] += va[4] + t.y, vb[5] += va[5] + t.z;
    for (int c = 0; c < 6; ++c) va[c] = 0;
  }
}

void RigidMapping::expand(double* d) const {
  for (size_t k = 0; k < m_mapped.size(); ++k) {
    const double* db = d + 6 * m_bodies[k];
    double* fa = d + 6 * m_mapped[k];
    const Vec3 u = load3(db), w = load3(db + 3), r = load3(&m_offsets[3 * k]);
    const Vec3 x = u + cross(w, r);  // u - [r]x w
    fa[0] = x.x, fa[1] = x.y, fa[2] = x.z, fa[3] = w.x, fa[4] = w.y, fa[5] = w.z;
  }
}

void RigidMapping::set_geometric(const double* gradient) {
  for (size_t k = 0; k < m_mapped.size(); ++k) store3(&m_forces[3 * k], load3(gradient + 6 * m_mapped[k]));
}

namespace {
Mat3 geometric_block(const Vec3& f, const Vec3& r) {
  return 0.5 * (outer(f, r) + outer(r, f)) - dot(f, r) * identity3();
}
}  // namespace

void RigidMapping::add_geometric(const double* d, double* out) const {
  for (size_t k = 0; k < m_mapped.size(); ++k) {
    const int b = m_bodies[k];
    const Vec3 y = geometric_block(load3(&m_forces[3 * k]), load3(&m_offsets[3 * k])) * load3(d + 6 * b + 3);
    out[6 * b + 3] += y.x, out[6 * b + 4] += y.y, out[6 * b + 5] += y.z;
  }
}

void RigidMapping::reduce_diagonal_blocks(double* blocks) const {
  for (size_t k = 0; k < m_mapped.size(); ++k) {
    const int a = m_mapped[k], b = m_bodies[k];
    const Vec3 r = load3(&m_offsets[3 * k]);
    double J[36] = {0};
    for (int c = 0; c < 6; ++c) J[6 * c + c] = 1;
    const Mat3 mr = -1.0 * skew(r);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) J[6 * i + 3 + j] = mr.m[i][j];
    const double* Ba = blocks + 36 * a;
    double BJ[36] = {0};
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j)
        for (int l = 0; l < 6; ++l) BJ[6 * i + j] += Ba[6 * i + l] * J[6 * l + j];
    double* Bb = blocks + 36 * b;
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j)
        for (int l = 0; l < 6; ++l) Bb[6 * i + j] += J[6 * l + i] * BJ[6 * l + j];
    const Mat3 G = geometric_block(load3(&m_forces[3 * k]), r);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) Bb[6 * (3 + i) + 3 + j] += G.m[i][j];
  }
  for (int a : m_mapped)
    for (int i = 0; i < 36; ++i) blocks[36 * a + i] = (i % 7 == 0) ? 1.0 : 0.0;
}

Eigen::SparseMatrix<double> RigidMapping::projection(int dof_count) const {
  std::vector<char> is_mapped(dof_count / 6, 0);
  for (int a : m_mapped) is_mapped[a] = 1;
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < dof_count / 6; ++i)
    if (!is_mapped[i])
      for (int c = 0; c < 6; ++c) t.emplace_back(6 * i + c, 6 * i + c, 1.0);
  for (size_t k = 0; k < m_mapped.size(); ++k) {
    const int a = m_mapped[k], b = m_bodies[k];
    const Mat3 mr = -1.0 * skew(load3(&m_offsets[3 * k]));
    for (int c = 0; c < 6; ++c) t.emplace_back(6 * a + c, 6 * b + c, 1.0);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (mr.m[i][j] != 0) t.emplace_back(6 * a + i, 6 * b + 3 + j, mr.m[i][j]);
  }
  Eigen::SparseMatrix<double> P(dof_count, dof_count);
  P.setFromTriplets(t.begin(), t.end());
  return P;
}

Eigen::SparseMatrix<double> RigidMapping::geometric_matrix(int dof_count) const {
  std::vector<Eigen::Triplet<double>> t;
  for (size_t k = 0; k < m_mapped.size(); ++k) {
    const int b = m_bodies[k];
    const Mat3 G = geometric_block(load3(&m_forces[3 * k]), load3(&m_offsets[3 * k]));
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) t.emplace_back(6 * b + 3 + i, 6 * b + 3 + j, G.m[i][j]);
  }
  Eigen::SparseMatrix<double> G(dof_count, dof_count);
  G.setFromTriplets(t.begin(), t.end());
  return G;
}

std::vector<std::uint8_t> RigidMapping::reduced_fixed(const Model& model) const {
  std::vector<std::uint8_t> fixed = model.fixed_dofs;
  fixed.resize(model.dof_count(), 0);
  for (int a : m_mapped)
    for (int c = 0; c < 6; ++c) fixed[6 * a + c] = 1;
  return fixed;
}

}  // namespace fascia
