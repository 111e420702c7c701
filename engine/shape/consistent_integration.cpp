#include "shape/consistent_integration.hpp"

#include "solve/pcg.hpp"
#include "solve/sparse_cholesky.hpp"
#include "solve/vector_ops.hpp"

#include <Eigen/Dense>
#include <Eigen/SparseCore>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

namespace fascia {
namespace {

using Vec4 = Eigen::Vector4d;
using Mat4 = Eigen::Matrix4d;

// Per frame and gradient component k, the defects of (a) and (b) (header), rows
// [(a)_k, (b)_{0k} / rho_i, (b)_{1k} / rho_i, (b)_{2k} / rho_i]: boundary minus
// samples. Layout [N][3][4].
std::vector<double> frame_defects(const NeighbourTable &nb,
                                  const std::vector<double> &volumes,
                                  const MeshlessShape &shape,
                                  const NeighbourTable &boundary,
                                  const std::vector<double> &normals) {
  const int n = static_cast<int>(shape.supports.size());
  std::vector<double> t(static_cast<size_t>(n) * 12, 0.0);
  const auto add = [&](const NeighbourTable &table, int q, double scale,
                       const Vec3 &direction, bool sample) {
    for (int p = table.offsets[q]; p < table.offsets[q + 1]; ++p) {
      const int i = table.frames[p];
      const double rho = shape.supports[i];
      const Vec3 l = load3(&table.rest_offsets[3 * p]); // point - x_i
      const double w = table.weights[p];
      // Boundary: w a_k and w l_m a_k. Samples: v g_k and v (l_m g_k + w
      // delta_mk).
      const Vec3 d =
          sample ? load3(&table.weight_gradients[3 * p]) : w * direction;
      double *ti = &t[12 * static_cast<size_t>(i)];
      for (int k = 0; k < 3; ++k) {
        const double dk = (&d.x)[k];
        ti[4 * k] += scale * dk;
        for (int m = 0; m < 3; ++m)
          ti[4 * k + 1 + m] +=
              scale * ((&l.x)[m] * dk + (sample && m == k ? w : 0.0)) / rho;
      }
    }
  };
  // Sequential: frames receive from many points; the sums are cheap next to the
  // solve.
  for (int q = 0; q + 1 < static_cast<int>(boundary.offsets.size()); ++q)
    add(boundary, q, 1.0, load3(&normals[3 * q]), false);
  for (int s = 0; s + 1 < static_cast<int>(nb.offsets.size()); ++s)
    add(nb, s, -volumes[s], Vec3{0, 0, 0}, true);
  return t;
}

double max_defect(const std::vector<double> &t) {
  double m = 0;
  for (size_t i = 0; i < t.size() / 4; ++i)
    m = std::max(m,
                 std::sqrt(t[4 * i] * t[4 * i] + t[4 * i + 1] * t[4 * i + 1] +
                           t[4 * i + 2] * t[4 * i + 2] +
                           t[4 * i + 3] * t[4 * i + 3]));
  return m;
}

double dot(const std::vector<double> &a, const std::vector<double> &b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i)
    s += a[i] * b[i];
  return s;
}

// The eliminated system of one gradient component: H lambda with lambda, result
// [N][4].
class FrameSystem {
public:
  FrameSystem(const NeighbourTable &nb, const std::vector<double> &volumes,
              const MeshlessShape &shape)
      : m_nb(nb), m_volumes(volumes) {
    const int s_count = static_cast<int>(volumes.size());
    const int n = static_cast<int>(shape.supports.size());
    const int pairs = static_cast<int>(nb.frames.size());
    m_e.resize(pairs), m_k.resize(pairs), m_gram.resize(s_count),
        m_c.resize(pairs);
#pragma omp parallel for schedule(static)
    for (int s = 0; s < s_count; ++s) {
      double L = 0;
      for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p)
        L += shape.supports[nb.frames[p]];
      L /= std::max(1, nb.offsets[s + 1] - nb.offsets[s]);
      Mat4 KK = Mat4::Zero();
      for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) {
        const Vec3 l = load3(&nb.rest_offsets[3 * p]); // p_s - x_i
        const double rho = shape.supports[nb.frames[p]];
        m_e[p] = Vec4(1, l.x / rho, l.y / rho, l.z / rho);
        m_k[p] = Vec4(1, -l.x / L, -l.y / L, -l.z / L);
        KK += m_k[p] * m_k[p].transpose();
      }
      // K K^T is the unweighted moment matrix of the sample's frames:
      // invertible wherever MLS is.
      m_gram[s] = KK.ldlt().solve(Mat4::Identity());
    }
    // Pairs of each frame, for the gather (deterministic, parallel over
    // frames).
    m_frame_offsets.assign(n + 1, 0);
    for (int p = 0; p < pairs; ++p)
      ++m_frame_offsets[nb.frames[p] + 1];
    for (int i = 0; i < n; ++i)
      m_frame_offsets[i + 1] += m_frame_offsets[i];
    m_frame_pairs.resize(pairs), m_pair_sample.resize(pairs);
    std::vector<int> cursor(m_frame_offsets.begin(), m_frame_offsets.end() - 1);
    for (int s = 0; s < s_count; ++s)
      for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) {
        m_frame_pairs[cursor[nb.frames[p]]++] = p;
        m_pair_sample[p] = s;
      }
    m_frames = n;
  }

  // The lower triangle of H [4N x 4N] (the blocks of rows i >= j in column block j, which is what
  // the factorisation reads): block (i_p, i_q) = sum_s v_s^2 (Pi_s)_pq e_p e_q^T over the pairs
  // p, q of each sample s, with (Pi_s)_pq = delta_pq - k_p^T G_s k_q. Column block j is formed
  // from frame j's pairs alone (in sample order), in parallel over frames.
  Eigen::SparseMatrix<double> assemble() const {
    const int n = m_frames;
    // Rows of column block j: the frames i >= j of every sample that has frame j, sorted.
    std::vector<std::vector<int>> adjacency(n);
#pragma omp parallel
    {
      std::vector<int> seen(n, -1);
#pragma omp for schedule(dynamic, 16)
      for (int j = 0; j < n; ++j) {
        std::vector<int> &rows = adjacency[j];
        for (int a = m_frame_offsets[j]; a < m_frame_offsets[j + 1]; ++a) {
          const int s = m_pair_sample[m_frame_pairs[a]];
          for (int p = m_nb.offsets[s]; p < m_nb.offsets[s + 1]; ++p)
            if (m_nb.frames[p] >= j && seen[m_nb.frames[p]] != j) {
              seen[m_nb.frames[p]] = j;
              rows.push_back(m_nb.frames[p]);
            }
        }
        std::sort(rows.begin(), rows.end());
      }
    }
    std::vector<int> outer(4 * static_cast<size_t>(n) + 1, 0);
    for (int j = 0; j < n; ++j)
      for (int c = 0; c < 4; ++c)
        outer[4 * j + c + 1] = outer[4 * j + c] + 4 * static_cast<int>(adjacency[j].size());
    Eigen::SparseMatrix<double> H(4 * n, 4 * n);
    H.resizeNonZeros(outer.back());
    std::copy(outer.begin(), outer.end(), H.outerIndexPtr());
    int *inner = H.innerIndexPtr();
    double *values = H.valuePtr();
#pragma omp parallel
    {
      std::vector<int> slot(n, 0);
#pragma omp for schedule(dynamic, 16)
      for (int j = 0; j < n; ++j) {
        const std::vector<int> &rows = adjacency[j];
        for (size_t k = 0; k < rows.size(); ++k)
          slot[rows[k]] = static_cast<int>(k);
        for (int c = 0; c < 4; ++c) {
          int at = outer[4 * j + c];
          std::fill(values + at, values + outer[4 * j + c + 1], 0.0);
          for (int i : rows)
            for (int r = 0; r < 4; ++r)
              inner[at++] = 4 * i + r;
        }
        for (int a = m_frame_offsets[j]; a < m_frame_offsets[j + 1]; ++a) {
          const int q = m_frame_pairs[a], s = m_pair_sample[q];
          const double v2 = m_volumes[s] * m_volumes[s];
          const Vec4 gk = m_gram[s] * m_k[q];
          const Vec4 &eq = m_e[q];
          for (int p = m_nb.offsets[s]; p < m_nb.offsets[s + 1]; ++p) {
            if (m_nb.frames[p] < j) continue;
            const double f = v2 * ((p == q ? 1.0 : 0.0) - m_k[p].dot(gk));
            const Vec4 &ep = m_e[p];
            const int at = 4 * slot[m_nb.frames[p]];
            for (int c = 0; c < 4; ++c) {
              double *column = values + outer[4 * j + c] + at;
              for (int r = 0; r < 4; ++r)
                column[r] += f * eq[c] * ep[r];
            }
          }
        }
      }
    }
    return H;
  }

  // y = H lambda; the pair corrections c = Pi E^T lambda are kept
  // (corrections()).
  void apply(const std::vector<double> &lambda, std::vector<double> &y) {
    const int s_count = static_cast<int>(m_volumes.size());
#pragma omp parallel for schedule(static)
    for (int s = 0; s < s_count; ++s) {
      const double v = m_volumes[s];
      Vec4 m = Vec4::Zero();
      for (int p = m_nb.offsets[s]; p < m_nb.offsets[s + 1]; ++p) {
        const Eigen::Map<const Vec4> l(
            &lambda[4 * static_cast<size_t>(m_nb.frames[p])]);
        m_c[p] = v * m_e[p].dot(l);
        m += m_c[p] * m_k[p];
      }
      const Vec4 mu = m_gram[s] * m;
      for (int p = m_nb.offsets[s]; p < m_nb.offsets[s + 1]; ++p)
        m_c[p] -= m_k[p].dot(mu);
    }
    const int n = m_frames;
    y.assign(4 * static_cast<size_t>(n), 0.0);
#pragma omp parallel for schedule(static)
    for (int i = 0; i < n; ++i) {
      Vec4 sum = Vec4::Zero();
      for (int a = m_frame_offsets[i]; a < m_frame_offsets[i + 1]; ++a) {
        const int p = m_frame_pairs[a];
        sum += m_volumes[m_pair_sample[p]] * m_c[p] * m_e[p];
      }
      Eigen::Map<Vec4> out(&y[4 * static_cast<size_t>(i)]);
      out = sum;
    }
  }

  const std::vector<double> &corrections() const { return m_c; }

private:
  const NeighbourTable &m_nb;
  const std::vector<double> &m_volumes;
  std::vector<Vec4> m_e,
      m_k;                  // [P] frame and sample constraint rows of each pair
  std::vector<Mat4> m_gram; // [S] (K_s K_s^T)^-1
  std::vector<double> m_c;  // [P] last corrections
  std::vector<int> m_frame_offsets, m_frame_pairs, m_pair_sample;
  int m_frames = 0;
};

// Orthonormal basis of the null space of H (16 vectors, header), in coordinates
// y = (x - c) / L centred and scaled on the frames for conditioning (the span
// does not depend on c and L):
//   lambda_i = [1, 0], [y_im, 0], [0, rho_i e_m], [y_ij y_il, rho_i y_il e_j]
//   (j, l = 0..2).
std::vector<std::vector<double>> null_space(const MeshlessShape &shape) {
  const int n = static_cast<int>(shape.supports.size());
  Vec3 c{0, 0, 0};
  for (int i = 0; i < n; ++i)
    c += load3(&shape.frames[3 * i]);
  c = (1.0 / n) * c;
  double L = 0;
  for (int i = 0; i < n; ++i)
    L = std::max(L, norm(load3(&shape.frames[3 * i]) - c));
  if (!(L > 0))
    L = 1;
  std::vector<std::vector<double>> z(
      16, std::vector<double>(4 * static_cast<size_t>(n), 0.0));
  for (int i = 0; i < n; ++i) {
    const Vec3 y = (1 / L) * (load3(&shape.frames[3 * i]) - c);
    const double rho = shape.supports[i] / L;
    z[0][4 * i] = 1;
    for (int m = 0; m < 3; ++m) {
      z[1 + m][4 * i] = (&y.x)[m];
      z[4 + m][4 * i + 1 + m] = rho;
    }
    for (int j = 0; j < 3; ++j)
      for (int l = 0; l < 3; ++l) {
        std::vector<double> &v = z[7 + 3 * j + l];
        v[4 * i] = (&y.x)[j] * (&y.x)[l];
        v[4 * i + 1 + j] = rho * (&y.x)[l];
      }
  }
  // Modified Gram-Schmidt, twice; a dependent vector (a planar cloud) is
  // dropped.
  std::vector<std::vector<double>> basis;
  for (auto &v : z) {
    const double size = std::sqrt(dot(v, v));
    for (int pass = 0; pass < 2; ++pass)
      for (const auto &b : basis) {
        const double d = dot(v, b);
        for (size_t j = 0; j < v.size(); ++j)
          v[j] -= d * b[j];
      }
    const double len = std::sqrt(dot(v, v));
    if (!(len > 1e-8 * size))
      continue;
    for (double &x : v)
      x /= len;
    basis.push_back(std::move(v));
  }
  return basis;
}

// Scales the volumes by 1 + a + b . (p_s - p_mean) so that they integrate 1 and
// x as the boundary rule does: sum v = V = (1/3) sum_q b_q . a_q and sum v p =
// (1/2) sum_q b_qm^2 a_qm (divergence theorem, exact for the degree-2 surface
// rule on a triangulation).
void fit_volume_moments(std::vector<double> &volumes,
                        const std::vector<double> &points,
                        const std::vector<double> &boundary_points,
                        const std::vector<double> &normals) {
  double V = 0;
  Vec3 first{0, 0, 0};
  for (size_t q = 0; q < normals.size() / 3; ++q) {
    const Vec3 b = load3(&boundary_points[3 * q]), a = load3(&normals[3 * q]);
    V += dot(b, a) / 3;
    first += Vec3{0.5 * b.x * b.x * a.x, 0.5 * b.y * b.y * a.y,
                  0.5 * b.z * b.z * a.z};
  }
  double sum = 0;
  Vec3 mean{0, 0, 0};
  for (size_t s = 0; s < volumes.size(); ++s)
    sum += volumes[s], mean += volumes[s] * load3(&points[3 * s]);
  if (!(sum > 0) || !(V > 0))
    throw std::invalid_argument("consistent integration: empty volume");
  mean = (1 / sum) * mean;
  Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
  for (size_t s = 0; s < volumes.size(); ++s) {
    const Vec3 d = load3(&points[3 * s]) - mean;
    const Eigen::Vector3d e(d.x, d.y, d.z);
    J += (volumes[s] * V / sum) * e * e.transpose();
  }
  // After scaling by V / sum: sum v (p - mean) = 0, so b moves the first moment
  // by J b.
  const Vec3 target = first - V * mean;
  const Eigen::Vector3d b =
      J.ldlt().solve(Eigen::Vector3d(target.x, target.y, target.z));
  for (size_t s = 0; s < volumes.size(); ++s) {
    const Vec3 d = load3(&points[3 * s]) - mean;
    const double factor =
        (V / sum) * (1 + b[0] * d.x + b[1] * d.y + b[2] * d.z);
    if (!(factor > 0))
      throw std::invalid_argument(
          "consistent integration: the samples' volumes cannot be fitted to "
          "the surface's moments (is every sample inside it?)");
    volumes[s] *= factor;
  }
}

} // namespace

ConsistentIntegrationReport make_integration_consistent(
    NeighbourTable &nb, std::vector<double> &volumes,
    const std::vector<double> &sample_points, const MeshlessShape &shape,
    const NeighbourTable &boundary, const std::vector<double> &boundary_points,
    const std::vector<double> &boundary_normals) {
  const int n = static_cast<int>(shape.supports.size());
  const int s_count = static_cast<int>(volumes.size());
  if (static_cast<int>(nb.offsets.size()) != s_count + 1)
    throw std::invalid_argument(
        "consistent integration: one volume per sample expected");
  if (boundary_normals.size() + 3 != 3 * boundary.offsets.size())
    throw std::invalid_argument(
        "consistent integration: one normal per boundary point expected");
  fit_volume_moments(volumes, sample_points, boundary_points, boundary_normals);
  // Scale of the sums: max_i sum_s v_s |grad w_is| (m^2).
  std::vector<double> frame_scale(n, 0.0);
  for (int s = 0; s < s_count; ++s)
    for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p)
      frame_scale[nb.frames[p]] +=
          volumes[s] * norm(load3(&nb.weight_gradients[3 * p]));
  const double scale = std::max(
      *std::max_element(frame_scale.begin(), frame_scale.end()), 1e-300);

  ConsistentIntegrationReport report;
  const std::vector<double> t =
      frame_defects(nb, volumes, shape, boundary, boundary_normals);
  report.initial_defect = max_defect(t) / scale;

  FrameSystem system(nb, volumes, shape);
  const std::vector<std::vector<double>> zero = null_space(shape);
  const size_t size = 4 * static_cast<size_t>(n);
  // Preconditioner: a sparse Cholesky factorisation of H + delta diag(H), H being singular (its
  // null space `zero`), its result projected off the null space, so that CG runs on the range of
  // H, where the factor inverts H up to delta: a few iterations instead of thousands with the
  // 4x4 diagonal blocks on fine clouds. delta = 1e-8 leaves the factor's pivots far above
  // round-off; diag(H) is floored at 1e-12 of its mean for frames that few samples see.
  Eigen::SparseMatrix<double> H = system.assemble();
  {
    double mean = 0;
    for (int k = 0; k < H.rows(); ++k)
      mean += H.coeff(k, k);
    mean /= std::max<Eigen::Index>(1, H.rows());
    for (int k = 0; k < H.rows(); ++k)
      H.coeffRef(k, k) += 1e-8 * std::max(H.coeff(k, k), 1e-12 * mean) + 1e-300;
  }
  SparseCholesky factor;
  if (!factor.factorise(H, nullptr))
    throw std::runtime_error("consistent integration: the frames' system could not be factorised");
  const auto project_off_null = [&zero](std::vector<double> &x) {
    for (const auto &v : zero) {
      const double c = dot(x, v);
      for (size_t j = 0; j < x.size(); ++j)
        x[j] -= c * v[j];
    }
  };
  const HostVectorOps ops(static_cast<int>(size), nullptr);
  auto apply = [&system](const std::vector<double> &x, std::vector<double> &y) { system.apply(x, y); };
  auto precondition = [&](const std::vector<double> &r, std::vector<double> &z) {
    factor.solve(r, z);
    project_off_null(z);
  };
  std::vector<double> b(size), lambda(size), q(size);
  const int pairs = static_cast<int>(nb.frames.size());
  std::vector<double> correction(3 * static_cast<size_t>(pairs), 0.0);
  // Conjugate gradients to round-off: the patch test is meant to hold to ~1e-10
  // and above.
  constexpr double kTolerance = 1e-13;
  PcgSettings settings;
  settings.max_iterations = 20000;
  for (int k = 0; k < 3; ++k) {
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < 4; ++j)
        b[4 * i + j] = t[12 * static_cast<size_t>(i) + 4 * k + j];
    project_off_null(b);
    const double b_norm = std::sqrt(dot(b, b));
    settings.tolerance =
        b_norm > 0 ? kTolerance * scale * std::sqrt(static_cast<double>(n)) / b_norm : 1.0;
    report.iterations += pcg(ops, apply, precondition, settings, b, lambda).iterations;
    system.apply(lambda, q); // leaves c = Pi E^T lambda
    const std::vector<double> &c = system.corrections();
    for (int p = 0; p < pairs; ++p)
      correction[3 * static_cast<size_t>(p) + k] = c[p];
  }
  for (size_t j = 0; j < correction.size(); ++j)
    nb.weight_gradients[j] += correction[j];
  report.defect = max_defect(frame_defects(nb, volumes, shape, boundary,
                                           boundary_normals)) /
                  scale;
  return report;
}

} // namespace fascia
