// Meshless shape functions: conforming fields (one per frame), partition of
// unity, linear precision (MLS), analytic gradients against finite differences
// of the fields.
#include "shape/meshless_shape.hpp"

#include <catch2/catch.hpp>

#include <map>
#include <random>
#include <vector>

using namespace fascia;

namespace {

// Frames on a jittered lattice of spacing 1 around the origin: an irregular,
// well-spread cloud.
std::vector<double> frame_cloud(unsigned seed, int half = 2) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  std::vector<double> x;
  for (int i = -half; i <= half; ++i)
    for (int j = -half; j <= half; ++j)
      for (int k = -half; k <= half; ++k)
        x.insert(x.end(), {i + u(rng), j + u(rng), k + u(rng)});
  return x;
}

struct Sums {
  double w = 0;
  Vec3 g{0, 0, 0}, wx{0, 0, 0};
  Mat3 xg = zero3();
};

// Sums over the neighbours of point q of a table: sum w, sum grad w, sum w x_i,
// sum x_i grad w^T.
Sums sums(const MeshlessShape &shape, const MeshlessTable &t, int q) {
  Sums s;
  const NeighbourTable &nb = t.neighbours;
  for (int p = nb.offsets[q]; p < nb.offsets[q + 1]; ++p) {
    const Vec3 x = load3(&shape.frames[3 * nb.frames[p]]),
               g = load3(&nb.weight_gradients[3 * p]);
    s.w += nb.weights[p], s.g += g, s.wx += nb.weights[p] * x;
    s.xg += outer(x, g);
  }
  return s;
}

// Weights of point q by frame index (frames outside the support have weight 0).
std::map<int, double> weights_by_frame(const MeshlessTable &t, int q) {
  std::map<int, double> w;
  for (int p = t.neighbours.offsets[q]; p < t.neighbours.offsets[q + 1]; ++p)
    w[t.neighbours.frames[p]] = t.neighbours.weights[p];
  return w;
}

} // namespace

TEST_CASE("Wendland C2 kernel and derivative", "[shape][meshless]") {
  REQUIRE(wendland_c2(0) == 1);
  REQUIRE(wendland_c2(1) == 0);
  REQUIRE(wendland_c2(1.5) == 0);
  for (double q : {0.1, 0.37, 0.8, 0.99}) {
    const double h = 1e-6; // cbrt(eps) scale: error ~ 1e-11
    REQUIRE(wendland_c2_derivative(q) ==
            Approx((wendland_c2(q + h) - wendland_c2(q - h)) / (2 * h))
                .margin(1e-9));
  }
}

TEST_CASE("frame supports follow the local frame spacing",
          "[shape][meshless]") {
  // A regular lattice of spacing 1: the 8th nearest neighbour of an interior
  // frame is at sqrt(2) (6 at distance 1, then 12 at sqrt(2)); of a corner
  // frame at sqrt(3) (3 at 1, 3 at sqrt(2), 1 at sqrt(3), then 3 at 2):
  // supports 1.6 sqrt(2) and 1.6 x 2.
  std::vector<double> x;
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j)
      for (int k = 0; k < 5; ++k)
        x.insert(x.end(), {double(i), double(j), double(k)});
  MeshlessShapeOptions options;
  options.support_neighbours = 8;
  options.support_scale = 1.6;
  const MeshlessShape shape = make_meshless_shape(x, options);
  REQUIRE(shape.supports[2 * 25 + 2 * 5 + 2] ==
          Approx(1.6 * std::sqrt(2.0)).epsilon(1e-14));
  REQUIRE(shape.supports[0] == Approx(1.6 * 2).epsilon(1e-14));
}

TEST_CASE("MLS fields: partition of unity and linear precision of weights and "
          "gradients",
          "[shape][meshless]") {
  const MeshlessShape shape =
      make_meshless_shape(frame_cloud(1), MeshlessShapeOptions{});
  const std::vector<double> points = {0,   0,   0,    0.3, -0.45, 0.1,
                                      1.2, 0.7, -1.1, 2.2, 2.1,   -2.25};
  const MeshlessTable t = build_meshless_table(shape, points);
  REQUIRE(t.failed.empty());
  for (int q = 0; q < 4; ++q) {
    const Sums s = sums(shape, t, q);
    const Vec3 p = load3(&points[3 * q]);
    // Round-off of sums of ~30 O(1) terms through a 4x4 solve with condition
    // ~1e2..1e4 (the last point is at a corner of the cloud): 1e-12.
    REQUIRE(s.w == Approx(1).epsilon(1e-12));
    REQUIRE(norm(s.g) <= 1e-12);
    REQUIRE(norm(s.wx - p) <= 1e-12); // sum w_i x_i = p
    REQUIRE(ddot(s.xg - identity3(), s.xg - identity3()) <=
            1e-24); // sum x_i grad w_i^T = I
  }
}

TEST_CASE("stored gradients are the derivatives of one field per frame",
          "[shape][meshless][fd]") {
  // Conformity: the table at x +- h e_k is built from scratch (its own
  // neighbour search), and the central difference of each frame's weight
  // matches the gradient stored at x. With fields that depended on the
  // evaluation point's own neighbourhood (k nearest frames, a support per
  // point) the differences would see the jumps between neighbourhoods.
  const MeshlessShape shape =
      make_meshless_shape(frame_cloud(3), MeshlessShapeOptions{});
  const Vec3 c = GENERATE(Vec3{0.2, 0.1, -0.3}, Vec3{1.3, -0.8, 1.9},
                          Vec3{-2.1, 2.0, 0.4});
  const MeshlessTable t = build_meshless_table(shape, {c.x, c.y, c.z});
  REQUIRE(t.failed.empty());
  double scale = 0;
  for (size_t p = 0; p < t.neighbours.frames.size(); ++p)
    scale = std::max(scale, norm(load3(&t.neighbours.weight_gradients[3 * p])));
  // Central differences with h = 1e-5 (supports ~2): truncation h^2 |w'''| ~
  // 1e-10, round-off eps / h ~ 1e-11; 1e-7 |grad w|max leaves a wide margin and
  // still sees any O(1) mismatch.
  const double h = 1e-5;
  for (int k = 0; k < 3; ++k) {
    Vec3 e{0, 0, 0};
    (&e.x)[k] = h;
    const Vec3 a = c + e, b = c - e;
    const MeshlessTable tp = build_meshless_table(shape, {a.x, a.y, a.z});
    const MeshlessTable tm = build_meshless_table(shape, {b.x, b.y, b.z});
    std::map<int, double> wp = weights_by_frame(tp, 0),
                          wm = weights_by_frame(tm, 0);
    for (int p = t.neighbours.offsets[0]; p < t.neighbours.offsets[1]; ++p) {
      const int i = t.neighbours.frames[p];
      const double fd = (wp[i] - wm[i]) / (2 * h);
      INFO("frame " << i << " axis " << k << " fd " << fd << " analytic "
                    << t.neighbours.weight_gradients[3 * p + k]);
      REQUIRE(std::abs(fd - t.neighbours.weight_gradients[3 * p + k]) <=
              1e-7 * scale);
    }
  }
}

TEST_CASE("MLS refuses coplanar frames; the spread measure sees them",
          "[shape][meshless]") {
  std::vector<Vec3> x;
  for (int i = -2; i <= 2; ++i)
    for (int j = -2; j <= 2; ++j)
      x.push_back(Vec3{double(i), double(j), 0.0});
  const int n = static_cast<int>(x.size());
  std::vector<double> w(n), rho(n, 2.5);
  std::vector<Vec3> g(n);
  const Vec3 p{0.1, 0.2, 0.05};
  REQUIRE_FALSE(meshless_shape(p, x.data(), rho.data(), n, w.data(), g.data()));
  Vec3 weak;
  REQUIRE(neighbour_spread(p, x.data(), rho.data(), n, weak) < 1e-8);
  REQUIRE(std::abs(weak.z) == Approx(1).epsilon(1e-12));
  // Lifting the central frame off the plane restores a (poorly) spread cloud.
  x[12].z = 0.5;
  REQUIRE(meshless_shape(p, x.data(), rho.data(), n, w.data(), g.data()));
  REQUIRE(neighbour_spread(p, x.data(), rho.data(), n, weak) > 0);
}

TEST_CASE("meshless table: every frame whose support covers the point, no "
          "neighbour cap",
          "[shape][meshless]") {
  MeshlessShapeOptions options;
  options.support_neighbours =
      26; // large supports: far more than 16 frames per point
  const MeshlessShape shape = make_meshless_shape(frame_cloud(4), options);
  const std::vector<double> points = {0.1, 0.2,  0.3, -1.0, 0.5, 0.2,
                                      1.4, -1.3, 0.9, 9.0,  9.0, 9.0};
  const MeshlessTable t = build_meshless_table(shape, points);
  REQUIRE(t.failed ==
          std::vector<int>{3}); // the last point is outside every support
  REQUIRE(t.neighbours.offsets[1] > 40);
  for (int s = 0; s < 3; ++s) {
    int covering = 0;
    for (int i = 0; i < static_cast<int>(shape.supports.size()); ++i)
      covering += norm(load3(&shape.frames[3 * i]) - load3(&points[3 * s])) <
                  shape.supports[i];
    REQUIRE(t.neighbours.offsets[s + 1] - t.neighbours.offsets[s] == covering);
    double sw = 0;
    for (int p = t.neighbours.offsets[s]; p < t.neighbours.offsets[s + 1];
         ++p) {
      sw += t.neighbours.weights[p];
      const Vec3 l = load3(&t.neighbours.rest_offsets[3 * p]);
      const Vec3 x = load3(&shape.frames[3 * t.neighbours.frames[p]]);
      REQUIRE(norm(x + l - load3(&points[3 * s])) <= 1e-15); // eq. (2)
    }
    REQUIRE(sw == Approx(1).epsilon(1e-13));
  }
}

TEST_CASE("meshless table: a point's frames in increasing index; the weights "
          "alone are the full table's bits",
          "[shape][meshless]") {
  const MeshlessShape shape =
      make_meshless_shape(frame_cloud(5), MeshlessShapeOptions{});
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  std::vector<double> points;
  for (int s = 0; s < 200; ++s)
    points.insert(points.end(), {u(rng), u(rng), u(rng)});
  points.insert(points.end(), {9.0, 9.0, 9.0}); // outside every support
  const MeshlessTable full = build_meshless_table(shape, points);
  const MeshlessTable weights = build_meshless_table(shape, points, true);
  const NeighbourTable &a = full.neighbours, &b = weights.neighbours;
  for (int s = 0; s + 1 < static_cast<int>(a.offsets.size()); ++s)
    for (int p = a.offsets[s] + 1; p < a.offsets[s + 1]; ++p)
      REQUIRE(a.frames[p - 1] < a.frames[p]);
  REQUIRE(b.offsets == a.offsets);
  REQUIRE(b.frames == a.frames);
  REQUIRE(b.weights == a.weights); // bitwise: the same operations
  REQUIRE(b.rest_offsets == a.rest_offsets);
  REQUIRE(weights.failed == full.failed);
  REQUIRE(full.failed == std::vector<int>{200});
  REQUIRE(a.weight_gradients.size() == 3 * a.frames.size());
  REQUIRE(b.weight_gradients.empty());
  REQUIRE(weights.spreads.empty());
  REQUIRE(weights.weak_directions.empty());
}
