#include "shape/consistent_integration.hpp"

#include <Eigen/Dense>

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
    // Block-Jacobi: H_ii = sum_s v_s^2 (Pi_s)_ii e e^T, with (Pi_s)_ii = 1 -
    // k^T G_s k.
    m_preconditioner.resize(n);
#pragma omp parallel for schedule(static)
    for (int i = 0; i < n; ++i) {
      Mat4 D = Mat4::Zero();
      for (int a = m_frame_offsets[i]; a < m_frame_offsets[i + 1]; ++a) {
        const int p = m_frame_pairs[a], s = m_pair_sample[p];
        const double pii = std::max(0.0, 1 - m_k[p].dot(m_gram[s] * m_k[p]));
        D += volumes[s] * volumes[s] * pii * m_e[p] * m_e[p].transpose();
      }
      // A frame seen by fewer than 4 independent samples has a singular block:
      // regularise at round-off level relative to its trace.
      D += (1e-12 * D.trace() + 1e-300) * Mat4::Identity();
      m_preconditioner[i] = D.ldlt().solve(Mat4::Identity());
    }
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
    const int n = static_cast<int>(m_preconditioner.size());
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

  void precondition(const std::vector<double> &r,
                    std::vector<double> &z) const {
    const int n = static_cast<int>(m_preconditioner.size());
    z.resize(r.size());
#pragma omp parallel for schedule(static)
    for (int i = 0; i < n; ++i) {
      Eigen::Map<Vec4> out(&z[4 * static_cast<size_t>(i)]);
      out = m_preconditioner[i] *
            Eigen::Map<const Vec4>(&r[4 * static_cast<size_t>(i)]);
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
  std::vector<Mat4> m_preconditioner; // [N] inverse diagonal blocks
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
  std::vector<double> b(size), lambda(size), r(size), z(size), d(size), q(size);
  const int pairs = static_cast<int>(nb.frames.size());
  std::vector<double> correction(3 * static_cast<size_t>(pairs), 0.0);
  // Conjugate gradients to round-off: the patch test is meant to hold to ~1e-10
  // and above.
  constexpr double kTolerance = 1e-13;
  constexpr int kMaxIterations = 20000;
  for (int k = 0; k < 3; ++k) {
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < 4; ++j)
        b[4 * i + j] = t[12 * static_cast<size_t>(i) + 4 * k + j];
    for (const auto &v : zero) {
      const double c = dot(b, v);
      for (size_t j = 0; j < size; ++j)
        b[j] -= c * v[j];
    }
    const double target =
        kTolerance * scale * std::sqrt(static_cast<double>(n));
    std::fill(lambda.begin(), lambda.end(), 0.0);
    r = b;
    system.precondition(r, z);
    d = z;
    double rz = dot(r, z);
    for (int it = 0; it < kMaxIterations && std::sqrt(dot(r, r)) > target;
         ++it, ++report.iterations) {
      system.apply(d, q);
      const double dq = dot(d, q);
      if (!(dq > 0))
        break;
      const double alpha = rz / dq;
      for (size_t j = 0; j < size; ++j)
        lambda[j] += alpha * d[j], r[j] -= alpha * q[j];
      system.precondition(r, z);
      const double rz_next = dot(r, z);
      const double beta = rz_next / rz;
      rz = rz_next;
      for (size_t j = 0; j < size; ++j)
        d[j] = z[j] + beta * d[j];
    }
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
