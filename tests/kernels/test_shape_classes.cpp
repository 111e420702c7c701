// Shape classes (kernels/shape_classes.hpp): every pair's w and g rebuilt from its sample's class
// and map, on mesh-based models with distorted elements; none for meshless shape functions.
#include "shape_classes.hpp"

#include "discretise/mesh_based.hpp"
#include "support/fixtures.hpp"
#include "support/meshless_fixtures.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <random>

namespace fascia::gpu {
namespace {

// A box mesh whose interior vertices are moved by up to `jitter` times the cell size along each
// axis, so that no two elements have the same Jacobian.
VolumeMesh distorted_box(CellType type, double jitter) {
  const Vec3 lo{0, 0, 0}, hi{0.2, 0.1, 0.05};
  const int nx = 4, ny = 3, nz = 2;
  VolumeMesh mesh = type == CellType::hexahedron ? box_hex_mesh(lo, hi, nx, ny, nz) : box_tet_mesh(lo, hi, nx, ny, nz);
  const double h[3] = {0.2 / nx, 0.1 / ny, 0.05 / nz}, extent[3] = {0.2, 0.1, 0.05};
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    bool interior = true;
    for (int k = 0; k < 3; ++k) {
      const double c = mesh.vertices[3 * v + k];
      interior = interior && c > 1e-9 && c < extent[k] - 1e-9;
    }
    if (interior)
      for (int k = 0; k < 3; ++k) mesh.vertices[3 * v + k] += jitter * h[k] * u(rng);
  }
  return mesh;
}

// Largest |w_c - w| and |A_s r - g| / max |g| over all pairs, from the classes alone.
double largest_rebuild_error(const NeighbourTable& nb, const ShapeClasses& c) {
  double error = 0;
  for (size_t s = 0; s + 1 < nb.offsets.size(); ++s) {
    const int p0 = nb.offsets[s], count = nb.offsets[s + 1] - p0;
    const int first = c.class_offsets[c.sample_class[s]];
    REQUIRE(c.class_offsets[c.sample_class[s] + 1] - first == count);
    Mat3 A;
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) A.m[r][k] = c.sample_maps[9 * s + 3 * r + k];
    double largest = 0;
    for (int a = 0; a < count; ++a) largest = std::max(largest, norm(load3(&nb.weight_gradients[3 * (p0 + a)])));
    for (int a = 0; a < count; ++a) {
      const double* ref = &c.class_pairs[4 * static_cast<size_t>(first + a)];
      error = std::max(error, std::fabs(ref[0] - nb.weights[p0 + a]));
      const Vec3 g = A * Vec3{ref[1], ref[2], ref[3]};
      error = std::max(error, norm(g - load3(&nb.weight_gradients[3 * (p0 + a)])) / largest);
    }
  }
  return error;
}

}  // namespace

TEST_CASE("shape classes rebuild every pair of distorted mesh-based models", "[kernels][layout]") {
  const CellType type = GENERATE(CellType::hexahedron, CellType::tetrahedron);
  const Model model =
      build_mesh_model(distorted_box(type, 0.2), make_material(MaterialLaw::stvk, 1.0e4, 0.3, 1000.0), {});
  const std::optional<ShapeClasses> c = find_shape_classes(model.neighbours, 64);
  REQUIRE(c.has_value());
  // One class per quadrature point of the reference element (8 for 2 x 2 x 2 hexahedron points;
  // tetrahedra: the 4 points, times the node orders the box's split gives).
  if (type == CellType::hexahedron) CHECK(c->class_count() == 8);
  CHECK(c->class_count() <= model.sample_count() / 4);
  // The maps are not the identity: distortion changes every element's Jacobian.
  double off_identity = 0;
  for (int s = 0; s < model.sample_count(); ++s)
    for (int k = 0; k < 9; ++k)
      off_identity = std::max(off_identity, std::fabs(c->sample_maps[9 * s + k] - (k % 4 == 0 ? 1.0 : 0.0)));
  CHECK(off_identity > 0.05);
  // Least-squares maps of exactly mapped gradients: rounding only (1e-12 is the acceptance bound).
  CHECK(c->max_error < 1e-12);
  CHECK(largest_rebuild_error(model.neighbours, *c) < 1e-12);
}

TEST_CASE("shape classes are refused where pairs fit no class", "[kernels][layout]") {
  SECTION("meshless shape functions give nearly every sample its own weights") {
    const MeshlessBuild build = test::small_meshless_box(MeshlessShapeKind::mls);
    const int S = build.model.sample_count();
    const std::optional<ShapeClasses> c = find_shape_classes(build.model.neighbours, S);
    // Without a cap, classes exist trivially (a class per sample, A_s = I) but save nothing: the
    // device takes them only at one class per 4 samples or fewer.
    CHECK((!c.has_value() || 4 * c->class_count() > S));
    CHECK_FALSE(find_shape_classes(build.model.neighbours, 16).has_value());
  }
  SECTION("equal weights but gradients that no linear map relates") {
    const Model model = test::small_box_model(CellType::hexahedron, MaterialLaw::stvk, 2, 2, 1);
    NeighbourTable nb = model.neighbours;
    REQUIRE(find_shape_classes(nb, 64).has_value());
    nb.weight_gradients[3 * nb.offsets[model.sample_count() - 1] + 1] *= 1.001;  // one component of one pair
    CHECK_FALSE(find_shape_classes(nb, 64).has_value());
  }
  SECTION("more classes than allowed") {
    const Model model = test::small_box_model(CellType::hexahedron, MaterialLaw::stvk, 2, 2, 1);
    CHECK(find_shape_classes(model.neighbours, 8).has_value());
    CHECK_FALSE(find_shape_classes(model.neighbours, 7).has_value());
  }
}

}  // namespace fascia::gpu
