#include "discretise/probe.hpp"

#include "core/rotation.hpp"
#include "shape/element_shape.hpp"

#include <cmath>
#include <stdexcept>

namespace fascia {
namespace {

constexpr double kInside = 1e-9;

template <int K>
Probe finish(const VolumeMesh& mesh, int cell, const std::array<double, K>& w, const Vec3& point) {
  Probe p;
  p.rest_position = point;
  for (int a = 0; a < K; ++a) {
    const int v = mesh.cells[K * cell + a];
    p.frames.push_back(v);
    p.weights.push_back(w[a]);
    const Vec3 l = point - load3(&mesh.vertices[3 * v]);
    p.rest_offsets.insert(p.rest_offsets.end(), {l.x, l.y, l.z});
  }
  return p;
}

}  // namespace

Probe make_probe(const VolumeMesh& mesh, const Vec3& point) {
  const int k = mesh.nodes_per_cell();
  for (int c = 0; c < mesh.cell_count(); ++c) {
    Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
    for (int a = 0; a < k; ++a) {
      const Vec3 x = load3(&mesh.vertices[3 * mesh.cells[k * c + a]]);
      lo = Vec3{std::min(lo.x, x.x), std::min(lo.y, x.y), std::min(lo.z, x.z)};
      hi = Vec3{std::max(hi.x, x.x), std::max(hi.y, x.y), std::max(hi.z, x.z)};
    }
    const double pad = 1e-9 * norm(hi - lo);
    if (point.x < lo.x - pad || point.y < lo.y - pad || point.z < lo.z - pad || point.x > hi.x + pad ||
        point.y > hi.y + pad || point.z > hi.z + pad)
      continue;
    if (mesh.type == CellType::tetrahedron) {
      std::array<Vec3, 4> X;
      for (int a = 0; a < 4; ++a) X[a] = load3(&mesh.vertices[3 * mesh.cells[4 * c + a]]);
      const Mat3 D = Mat3{{{X[1].x - X[0].x, X[2].x - X[0].x, X[3].x - X[0].x},
                           {X[1].y - X[0].y, X[2].y - X[0].y, X[3].y - X[0].y},
                           {X[1].z - X[0].z, X[2].z - X[0].z, X[3].z - X[0].z}}};
      const Vec3 xi = transpose(inverse_transpose(D)) * (point - X[0]);
      const std::array<double, 4> w{1 - xi.x - xi.y - xi.z, xi.x, xi.y, xi.z};
      if (w[0] >= -kInside && w[1] >= -kInside && w[2] >= -kInside && w[3] >= -kInside)
        return finish<4>(mesh, c, w, point);
    } else {
      std::array<Vec3, 8> X;
      for (int a = 0; a < 8; ++a) X[a] = load3(&mesh.vertices[3 * mesh.cells[8 * c + a]]);
      std::array<double, 3> xi{0, 0, 0};
      // Newton inversion of the trilinear map (converges in a few steps for convex cells).
      for (int it = 0; it < 30; ++it) {
        const ElementShape<8> sh = hex_trilinear_shape(X, xi);
        Vec3 x{0, 0, 0};
        for (int a = 0; a < 8; ++a) x += sh.weights[a] * X[a];
        const Mat3 J = hex_trilinear_jacobian(X, xi);
        const Vec3 step = transpose(inverse_transpose(J)) * (point - x);
        xi[0] += step.x, xi[1] += step.y, xi[2] += step.z;
        if (norm(step) < 1e-14) break;
      }
      if (std::abs(xi[0]) <= 1 + kInside && std::abs(xi[1]) <= 1 + kInside && std::abs(xi[2]) <= 1 + kInside)
        return finish<8>(mesh, c, hex_trilinear_shape(X, xi).weights, point);
    }
  }
  throw std::invalid_argument("probe point lies outside the mesh");
}

Probe make_meshless_probe(const MeshlessShape& shape, const Vec3& point) {
  const MeshlessTable table = build_meshless_table(shape, {point.x, point.y, point.z});
  if (!table.failed.empty()) throw std::invalid_argument("meshless shape functions cannot be built at the probe point");
  Probe p;
  p.rest_position = point;
  p.frames = table.neighbours.frames;
  p.weights = table.neighbours.weights;
  p.rest_offsets = table.neighbours.rest_offsets;
  return p;
}

Vec3 probe_position(const Probe& probe, const State& state) {
  Vec3 p{0, 0, 0};
  for (size_t a = 0; a < probe.frames.size(); ++a) {
    const int i = probe.frames[a];
    const Mat3 R = rotation_matrix(load_quat(&state.orientations[4 * i]));
    p += probe.weights[a] * (load3(&state.positions[3 * i]) + R * load3(&probe.rest_offsets[3 * a]));
  }
  return p;
}

}  // namespace fascia
