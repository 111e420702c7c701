#include "shape/meshless_shape.hpp"

#include <Eigen/Dense>
#include <nanoflann.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace fascia {

double wendland_c2(double q) {
  if (q >= 1)
    return 0;
  const double a = 1 - q;
  return a * a * a * a * (4 * q + 1);
}

double wendland_c2_derivative(double q) {
  if (q >= 1)
    return 0;
  const double a = 1 - q;
  return -20 * q * a * a * a;
}

namespace {

// Kernel value and gradient with respect to x: grad phi = phi'(q) (x - x_i) /
// (|x - x_i| rho) = -20 (1 - q)^3 (x - x_i) / rho^2 (smooth at x = x_i).
void kernel(const Vec3 &x, const Vec3 &xi, double rho, double &phi,
            Vec3 &grad) {
  const Vec3 d = x - xi;
  const double q = norm(d) / rho;
  if (q >= 1) {
    phi = 0, grad = Vec3{0, 0, 0};
    return;
  }
  const double a = 1 - q;
  phi = a * a * a * a * (4 * q + 1);
  grad = (-20 * a * a * a / (rho * rho)) * d;
}

} // namespace

bool meshless_shape(const Vec3 &x, const Vec3 *frames, const double *supports,
                    int count, double *weights, Vec3 *gradients) {
  // Kernel values are stored in the outputs first.
  double sum = 0, h = 0;
  for (int i = 0; i < count; ++i) {
    if (gradients)
      kernel(x, frames[i], supports[i], weights[i], gradients[i]);
    else
      weights[i] = wendland_c2(norm(x - frames[i]) / supports[i]);
    sum += weights[i];
    h += supports[i];
  }
  if (!(sum > 0))
    return false;
  // Basis P(y) = [1, (y - x) / h]; P_i = P(x_i) is taken with the centre fixed,
  // which gives the derivative of the field since the field does not depend on
  // the centre.
  h /= count;
  using Vec4 = Eigen::Vector4d;
  Eigen::Matrix4d A = Eigen::Matrix4d::Zero();
  Eigen::Matrix4d dA[3] = {Eigen::Matrix4d::Zero(), Eigen::Matrix4d::Zero(),
                           Eigen::Matrix4d::Zero()};
  const auto basis = [&](const Vec3 &y) {
    const Vec3 d = (1 / h) * (y - x);
    return Vec4(1, d.x, d.y, d.z);
  };
  for (int i = 0; i < count; ++i) {
    const Vec4 P = basis(frames[i]);
    const Eigen::Matrix4d PP = P * P.transpose();
    A += weights[i] * PP;
    if (gradients)
      dA[0] += gradients[i].x * PP, dA[1] += gradients[i].y * PP,
          dA[2] += gradients[i].z * PP;
  }
  const Eigen::LDLT<Eigen::Matrix4d> ldlt(A);
  // A is positive semi-definite; relative pivot below 1e-12 means a (near)
  // rank-deficient cloud.
  const Vec4 D = ldlt.vectorD();
  if (ldlt.info() != Eigen::Success || !(D.minCoeff() > 1e-12 * D.maxCoeff()))
    return false;
  const Vec4 Px(1, 0, 0, 0);
  const Vec4 gamma = ldlt.solve(Px);
  if (!gradients) {
    for (int i = 0; i < count; ++i)
      weights[i] *= gamma.dot(basis(frames[i]));
    return true;
  }
  Vec4 dgamma[3];
  for (int k = 0; k < 3; ++k) {
    Vec4 dP = Vec4::Zero();
    dP[k + 1] = 1 / h;
    dgamma[k] =
        ldlt.solve(dP - dA[k] * gamma); // d(A^-1 P) = A^-1 (dP - dA A^-1 P)
  }
  for (int i = 0; i < count; ++i) {
    const Vec4 P = basis(frames[i]);
    const double phi = weights[i];
    const Vec3 dphi = gradients[i];
    const double gP = gamma.dot(P);
    weights[i] = phi * gP;
    gradients[i] = gP * dphi + phi * Vec3{dgamma[0].dot(P), dgamma[1].dot(P),
                                          dgamma[2].dot(P)};
  }
  return true;
}

double neighbour_spread(const Vec3 &x, const Vec3 *frames,
                        const double *supports, int count, Vec3 &weak) {
  double sum = 0, h = 0;
  Vec3 mean{0, 0, 0};
  for (int i = 0; i < count; ++i) {
    const double phi = wendland_c2(norm(x - frames[i]) / supports[i]);
    sum += phi;
    mean += phi * frames[i];
    h += supports[i];
  }
  weak = Vec3{0, 0, 1};
  if (!(sum > 0))
    return 0;
  h /= count;
  mean = (1 / sum) * mean;
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (int i = 0; i < count; ++i) {
    const double phi = wendland_c2(norm(x - frames[i]) / supports[i]);
    const Vec3 d = (1 / h) * (frames[i] - mean);
    const Eigen::Vector3d e(d.x, d.y, d.z);
    C += phi * e * e.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(C / sum);
  const Eigen::Vector3d l = eig.eigenvalues(); // increasing
  const Eigen::Vector3d v = eig.eigenvectors().col(0);
  weak = Vec3{v[0], v[1], v[2]};
  if (!(l[2] > 0))
    return 0;
  return std::sqrt(std::max(l[0], 0.0) / l[2]);
}

namespace {

struct FrameCloud {
  const std::vector<double> &xyz;
  size_t kdtree_get_point_count() const { return xyz.size() / 3; }
  double kdtree_get_pt(size_t i, size_t d) const { return xyz[3 * i + d]; }
  template <class Box> bool kdtree_get_bbox(Box &) const { return false; }
};

using FrameTree = nanoflann::KDTreeSingleIndexAdaptor<
    nanoflann::L2_Simple_Adaptor<double, FrameCloud>, FrameCloud, 3, int>;

struct Block { // the table rows of a contiguous range of samples
  std::vector<int> counts, frames;
  std::vector<double> weights, gradients, offsets, spreads, weak;
  std::vector<int> failed;
};

} // namespace

MeshlessShape make_meshless_shape(std::vector<double> frames,
                                  const MeshlessShapeOptions &options) {
  const int n = static_cast<int>(frames.size() / 3);
  if (n == 0)
    throw std::invalid_argument(
        "meshless shape functions need at least one frame");
  if (!(options.support_scale > 1))
    throw std::invalid_argument("support_scale must be greater than 1");
  if (options.support_neighbours < 1)
    throw std::invalid_argument("support_neighbours must be at least 1");
  MeshlessShape shape;
  shape.supports.assign(n, 0.0);
  if (n == 1) {
    shape.supports[0] = options.support_scale;
  } else {
    const FrameCloud cloud{frames};
    FrameTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16));
    tree.buildIndex();
    // The nearest frame found is the frame itself (distance 0).
    const int k = std::min(options.support_neighbours, n - 1) + 1;
#pragma omp parallel
    {
      std::vector<int> idx(k);
      std::vector<double> d2(k);
#pragma omp for schedule(static)
      for (int i = 0; i < n; ++i) {
        const int found = static_cast<int>(
            tree.knnSearch(&frames[3 * i], k, idx.data(), d2.data()));
        shape.supports[i] = options.support_scale * std::sqrt(d2[found - 1]);
      }
    }
    // Coincident frames would give a zero support: fall back to the largest
    // one.
    const double largest =
        *std::max_element(shape.supports.begin(), shape.supports.end());
    for (double &r : shape.supports)
      if (!(r > 0))
        r = largest > 0 ? largest : 1.0;
  }
  shape.frames = std::move(frames);
  return shape;
}

MeshlessTable build_meshless_table(const MeshlessShape &shape,
                                   const std::vector<double> &points,
                                   bool weights_only) {
  const std::vector<double> &frames = shape.frames;
  const int s_count = static_cast<int>(points.size() / 3);
  if (frames.empty())
    throw std::invalid_argument(
        "meshless shape functions need at least one frame");
  const double reach =
      *std::max_element(shape.supports.begin(), shape.supports.end());
  const FrameCloud cloud{frames};
  FrameTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16));
  tree.buildIndex();

  constexpr int kBlock = 2048;
  const int blocks = (s_count + kBlock - 1) / kBlock;
  std::vector<Block> out(blocks);
#pragma omp parallel
  {
    std::vector<int> idx;
    std::vector<std::pair<int, double>> matches;
    std::vector<Vec3> xs;
    std::vector<double> w, rho;
    std::vector<Vec3> g;
#pragma omp for schedule(dynamic, 1)
    for (int b = 0; b < blocks; ++b) {
      Block &blk = out[b];
      for (int s = b * kBlock; s < std::min(s_count, (b + 1) * kBlock); ++s) {
        const Vec3 p = load3(&points[3 * s]);
        idx.clear();
        matches.clear();
        // The frames within the largest support, in the tree's order (sorting
        // them by distance would cost as much as the search), then those whose
        // own support covers p, in increasing index: the frames are numbered
        // along a space-filling curve, so a sample's frames lie close in memory.
        tree.radiusSearch(&points[3 * s], reach * reach, matches,
                          nanoflann::SearchParams(32, 0, false));
        for (const auto &m : matches) {
          const double r = shape.supports[m.first];
          if (m.second < r * r)
            idx.push_back(m.first);
        }
        std::sort(idx.begin(), idx.end());
        bool ok = !idx.empty();
        if (!ok) { // no frame covers p: nearest frame, rigidly attached,
                   // reported as failed
          int nearest;
          double dn;
          tree.knnSearch(&points[3 * s], 1, &nearest, &dn);
          idx.push_back(nearest);
        }
        const int count = static_cast<int>(idx.size());
        xs.resize(count), w.resize(count), g.resize(count), rho.resize(count);
        for (int j = 0; j < count; ++j)
          xs[j] = load3(&frames[3 * idx[j]]), rho[j] = shape.supports[idx[j]];
        Vec3 weak{0, 0, 1};
        double spread = ok && !weights_only
                            ? neighbour_spread(p, xs.data(), rho.data(), count,
                                               weak)
                            : 0;
        ok = ok && meshless_shape(p, xs.data(), rho.data(), count, w.data(),
                                  weights_only ? nullptr : g.data());
        if (!ok) {
          blk.failed.push_back(s);
          spread = 0;
          std::fill(w.begin(), w.end(), 1.0 / count);
          std::fill(g.begin(), g.end(), Vec3{0, 0, 0});
        }
        blk.counts.push_back(count);
        for (int j = 0; j < count; ++j) {
          blk.frames.push_back(idx[j]);
          blk.weights.push_back(w[j]);
          if (!weights_only)
            blk.gradients.insert(blk.gradients.end(),
                                 {g[j].x, g[j].y, g[j].z});
          const Vec3 l = p - xs[j]; // eq. (2) with rest orientation I
          blk.offsets.insert(blk.offsets.end(), {l.x, l.y, l.z});
        }
        if (!weights_only) {
          blk.spreads.push_back(spread);
          blk.weak.insert(blk.weak.end(), {weak.x, weak.y, weak.z});
        }
      }
    }
  }
  MeshlessTable table;
  NeighbourTable &nb = table.neighbours;
  size_t pairs = 0;
  for (const Block &blk : out)
    pairs += blk.frames.size();
  nb.offsets.reserve(s_count + 1);
  nb.offsets.push_back(0);
  nb.frames.reserve(pairs), nb.weights.reserve(pairs);
  if (!weights_only)
    nb.weight_gradients.reserve(3 * pairs);
  nb.rest_offsets.reserve(3 * pairs);
  for (Block &blk : out) {
    for (int c : blk.counts)
      nb.offsets.push_back(nb.offsets.back() + c);
    nb.frames.insert(nb.frames.end(), blk.frames.begin(), blk.frames.end());
    nb.weights.insert(nb.weights.end(), blk.weights.begin(), blk.weights.end());
    nb.weight_gradients.insert(nb.weight_gradients.end(), blk.gradients.begin(),
                               blk.gradients.end());
    nb.rest_offsets.insert(nb.rest_offsets.end(), blk.offsets.begin(),
                           blk.offsets.end());
    table.spreads.insert(table.spreads.end(), blk.spreads.begin(),
                         blk.spreads.end());
    table.weak_directions.insert(table.weak_directions.end(), blk.weak.begin(),
                                 blk.weak.end());
    table.failed.insert(table.failed.end(), blk.failed.begin(),
                        blk.failed.end());
    blk = Block{};
  }
  return table;
}

} // namespace fascia
