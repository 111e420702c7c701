// Meshless shape functions: partition of unity, linear precision (MLS), analytic gradients.
#include "shape/meshless_shape.hpp"

#include <catch2/catch.hpp>

#include <random>
#include <vector>

using namespace fascia;

namespace {

// Frames on a jittered lattice of spacing 1 around the origin: an irregular, well-spread cloud.
std::vector<Vec3> frame_cloud(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  std::vector<Vec3> x;
  for (int i = -2; i <= 2; ++i)
    for (int j = -2; j <= 2; ++j)
      for (int k = -2; k <= 2; ++k) x.push_back(Vec3{i + u(rng), j + u(rng), k + u(rng)});
  return x;
}

struct Sums {
  double w = 0;
  Vec3 g{0, 0, 0}, wx{0, 0, 0};
  Mat3 xg = zero3();
};

Sums sums(const std::vector<Vec3>& x, const std::vector<double>& w, const std::vector<Vec3>& g) {
  Sums s;
  for (size_t i = 0; i < x.size(); ++i) {
    s.w += w[i], s.g += g[i], s.wx += w[i] * x[i];
    s.xg += outer(x[i], g[i]);
  }
  return s;
}

}  // namespace

TEST_CASE("Wendland C2 kernel and derivative", "[shape][meshless]") {
  REQUIRE(wendland_c2(0) == 1);
  REQUIRE(wendland_c2(1) == 0);
  REQUIRE(wendland_c2(1.5) == 0);
  for (double q : {0.1, 0.37, 0.8, 0.99}) {
    const double h = 1e-6;  // cbrt(eps) scale: error ~ 1e-11
    REQUIRE(wendland_c2_derivative(q) == Approx((wendland_c2(q + h) - wendland_c2(q - h)) / (2 * h)).margin(1e-9));
  }
}

TEST_CASE("MLS shape functions: partition of unity and linear precision", "[shape][meshless]") {
  const std::vector<Vec3> x = frame_cloud(1);
  const Vec3 p = GENERATE(Vec3{0, 0, 0}, Vec3{0.3, -0.45, 0.1}, Vec3{1.2, 0.7, -1.1});
  const double rho = 1.9;
  std::vector<double> w(x.size());
  std::vector<Vec3> g(x.size());
  REQUIRE(meshless_shape(MeshlessShapeKind::mls, p, x.data(), static_cast<int>(x.size()), rho, w.data(), g.data()));
  const Sums s = sums(x, w, g);
  // Round-off of sums of ~30 O(1) terms through a 4x4 solve with condition ~1e2: 1e-13.
  REQUIRE(s.w == Approx(1).epsilon(1e-13));
  REQUIRE(norm(s.g) <= 1e-13);
  REQUIRE(norm(s.wx - p) <= 1e-13);                   // sum w_i x_i = p
  REQUIRE(ddot(s.xg - identity3(), s.xg - identity3()) <= 1e-26);  // sum x_i grad w_i^T = I
}

TEST_CASE("Shepard RBF shape functions: partition of unity without linear precision", "[shape][meshless]") {
  const std::vector<Vec3> x = frame_cloud(2);
  const Vec3 p{0.3, -0.45, 0.1};
  std::vector<double> w(x.size());
  std::vector<Vec3> g(x.size());
  REQUIRE(meshless_shape(MeshlessShapeKind::rbf, p, x.data(), static_cast<int>(x.size()), 1.9, w.data(), g.data()));
  const Sums s = sums(x, w, g);
  REQUIRE(s.w == Approx(1).epsilon(1e-14));
  REQUIRE(norm(s.g) <= 1e-14);
  for (double wi : w) REQUIRE(wi >= 0);
  // On an irregular cloud the Shepard gradients do not reproduce the identity: this is the
  // documented limitation (affine patch test fails), and the test would notice if it vanished.
  REQUIRE(ddot(s.xg - identity3(), s.xg - identity3()) > 1e-4);
}

TEST_CASE("meshless weight gradients match finite differences of the sample's field", "[shape][meshless][fd]") {
  const MeshlessShapeKind kind = GENERATE(MeshlessShapeKind::mls, MeshlessShapeKind::rbf);
  const std::vector<Vec3> x = frame_cloud(3);
  const int n = static_cast<int>(x.size());
  const Vec3 c{0.2, 0.1, -0.3};
  const double rho = 1.7;
  std::vector<double> w(n), wp(n), wm(n);
  std::vector<Vec3> g(n), scratch(n);
  REQUIRE(meshless_shape(kind, c, c, x.data(), n, rho, w.data(), g.data()));
  double scale = 0;
  for (const Vec3& gi : g) scale = std::max(scale, norm(gi));
  // Central differences with h = cbrt(eps) * rho: error ~ eps^(2/3) |w'''| rho^2 ~ 1e-10 / rho.
  const double h = 6e-6 * rho;
  for (int k = 0; k < 3; ++k) {
    Vec3 e{0, 0, 0};
    (&e.x)[k] = h;
    REQUIRE(meshless_shape(kind, c + e, c, x.data(), n, rho, wp.data(), scratch.data()));
    REQUIRE(meshless_shape(kind, c - e, c, x.data(), n, rho, wm.data(), scratch.data()));
    for (int i = 0; i < n; ++i) {
      const double fd = (wp[i] - wm[i]) / (2 * h);
      INFO("frame " << i << " axis " << k << " fd " << fd << " analytic " << (&g[i].x)[k]);
      REQUIRE(std::abs(fd - (&g[i].x)[k]) <= 1e-7 * scale);
    }
  }
}

TEST_CASE("MLS refuses coplanar frames; the spread measure sees them", "[shape][meshless]") {
  std::vector<Vec3> x;
  for (int i = -2; i <= 2; ++i)
    for (int j = -2; j <= 2; ++j) x.push_back(Vec3{double(i), double(j), 0.0});
  std::vector<double> w(x.size());
  std::vector<Vec3> g(x.size());
  const Vec3 p{0.1, 0.2, 0.05};
  REQUIRE_FALSE(meshless_shape(MeshlessShapeKind::mls, p, x.data(), static_cast<int>(x.size()), 2.5, w.data(), g.data()));
  Vec3 weak;
  REQUIRE(neighbour_spread(p, x.data(), static_cast<int>(x.size()), 2.5, weak) < 1e-8);
  REQUIRE(std::abs(weak.z) == Approx(1).epsilon(1e-12));
  // Lifting the central frame off the plane restores a (poorly) spread cloud.
  x[12].z = 0.5;
  REQUIRE(meshless_shape(MeshlessShapeKind::mls, p, x.data(), static_cast<int>(x.size()), 2.5, w.data(), g.data()));
  REQUIRE(neighbour_spread(p, x.data(), static_cast<int>(x.size()), 2.5, weak) > 0);
}

TEST_CASE("meshless table: k nearest and support-radius modes, no neighbour cap", "[shape][meshless]") {
  std::vector<double> frames, samples;
  for (const Vec3& v : frame_cloud(4)) frames.insert(frames.end(), {v.x, v.y, v.z});
  samples = {0.1, 0.2, 0.3, -1.0, 0.5, 0.2, 1.4, -1.3, 0.9};
  MeshlessShapeOptions knn;
  knn.neighbours = 9;
  const MeshlessTable a = build_meshless_table(frames, samples, knn);
  for (int s = 0; s < 3; ++s) REQUIRE(a.neighbours.offsets[s + 1] - a.neighbours.offsets[s] == 9);
  MeshlessShapeOptions radius;
  radius.neighbours = 0;
  radius.support_radius = 2.6;  // ~ 4/3 pi 2.6^3 = 74 frames of unit density: far above 16
  const MeshlessTable b = build_meshless_table(frames, samples, radius);
  REQUIRE(b.neighbours.offsets[1] > 40);
  REQUIRE(b.failed.empty());
  for (const MeshlessTable* t : {&a, &b})
    for (int s = 0; s < 3; ++s) {
      double sw = 0;
      for (int p = t->neighbours.offsets[s]; p < t->neighbours.offsets[s + 1]; ++p) {
        sw += t->neighbours.weights[p];
        const Vec3 l = load3(&t->neighbours.rest_offsets[3 * p]);
        const Vec3 x = load3(&frames[3 * t->neighbours.frames[p]]);
        REQUIRE(norm(x + l - load3(&samples[3 * s])) <= 1e-15);  // eq. (2)
      }
      REQUIRE(sw == Approx(1).epsilon(1e-13));
    }
}
