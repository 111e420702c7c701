#include "discretise/mesh_based.hpp"

#include "shape/element_shape.hpp"
#include "shape/quadrature.hpp"

#include <stdexcept>
#include <string>

namespace fascia {
namespace {

template <int K>
void add_samples(Model& model, const std::array<Vec3, K>& X, const std::array<int, K>& nodes,
                 const std::vector<QuadraturePoint>& rule, int cell,
                 ElementShape<K> (*shape)(const std::array<Vec3, K>&, const std::array<double, 3>&)) {
  NeighbourTable& nb = model.neighbours;
  for (const QuadraturePoint& q : rule) {
    const ElementShape<K> sh = shape(X, q.xi);
    if (!(sh.jacobian_determinant > 0))
      throw std::invalid_argument("element " + std::to_string(cell) + " is degenerate or inverted");
    Vec3 p{0, 0, 0};
    for (int a = 0; a < K; ++a) p += sh.weights[a] * X[a];
    model.samples.rest_positions.insert(model.samples.rest_positions.end(), {p.x, p.y, p.z});
    model.samples.volumes.push_back(sh.jacobian_determinant * q.weight);
    model.samples.materials.push_back(0);
    // Trilinear frames have zero-energy rotation modes (rotation_stabilisation.hpp).
    model.samples.rotation_stabilised.push_back(K == 8 ? 1 : 0);
    for (int a = 0; a < K; ++a) {
      nb.frames.push_back(nodes[a]);
      nb.weights.push_back(sh.weights[a]);
      const Vec3 g = sh.gradients[a];
      nb.weight_gradients.insert(nb.weight_gradients.end(), {g.x, g.y, g.z});
      const Vec3 l = p - X[a];  // eq. (2) with rest orientation I
      nb.rest_offsets.insert(nb.rest_offsets.end(), {l.x, l.y, l.z});
    }
    nb.offsets.push_back(static_cast<int>(nb.frames.size()));
  }
}

template <int K>
void add_cells(Model& model, const VolumeMesh& mesh, const std::vector<QuadraturePoint>& rule,
               ElementShape<K> (*shape)(const std::array<Vec3, K>&, const std::array<double, 3>&)) {
  for (int c = 0; c < mesh.cell_count(); ++c) {
    std::array<Vec3, K> X;
    std::array<int, K> nodes;
    for (int a = 0; a < K; ++a) {
      nodes[a] = mesh.cells[K * c + a];
      if (nodes[a] < 0 || nodes[a] >= mesh.vertex_count())
        throw std::invalid_argument("element " + std::to_string(c) + " references a missing vertex");
      X[a] = load3(&mesh.vertices[3 * nodes[a]]);
    }
    add_samples<K>(model, X, nodes, rule, c, shape);
  }
}

}  // namespace

Model build_mesh_model(const VolumeMesh& mesh, const Material& material, const MeshDiscretisation& options) {
  Model model;
  model.frame_rest_positions = mesh.vertices;
  model.materials = {material};
  model.neighbours.offsets = {0};
  if (mesh.type == CellType::tetrahedron)
    add_cells<4>(model, mesh, tet_quadrature(options.quadrature ? options.quadrature : 4), &tet_linear_shape);
  else
    add_cells<8>(model, mesh, hex_quadrature(options.quadrature ? options.quadrature : 2), &hex_trilinear_shape);
  build_reverse_table(model);
  compute_frame_inertia(model);
  model.fixed_dofs.assign(model.dof_count(), 0);
  return model;
}

}  // namespace fascia
