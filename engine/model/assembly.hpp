// One mechanical system from several objects (paper §4.2): volumetric tissues (frames and
// samples from discretise/), shells (a frame per surface vertex) and rigid bodies (one frame at
// the centre of mass), coupled by
//  * sharing (Figure 5): each frame of object a within `distance` of object b's surface becomes
//    b's nearest frame. The samples of a keep their weights and weight gradients, and their rest
//    offsets are re-based on the new frame, l = p_s - x_b (eq. 2): every sample's rest position
//    and F = I at rest are unchanged. Both objects' forces and tangents then add into the same
//    degrees of freedom. Two frames of a merged into one frame of b become one neighbour of a
//    sample (weights and gradients summed; the offsets are equal after re-basing).
//  * attaching to a rigid body: frames of a within `distance` of the body's surface follow it
//    rigidly (Model::rigid_parents, mechanics/rigid_mapping.hpp).
// Distances are from a frame's rest position to the other object's rest surface triangles.
#pragma once

#include "discretise/surface_mesh.hpp"
#include "model/model.hpp"

#include <string>
#include <vector>

namespace fascia {

struct ShellProperties {
  double thickness = 0;  // m
  double young = 0;      // Pa
  double poisson = 0;
  double density = 0;    // kg/m^3
};

class ModelBuilder {
 public:
  // A volumetric object: `part` from discretise/ (frames, samples, materials, fixed DOFs), and
  // its boundary surface (for couplings and output). Returns the object's index.
  int add_tissue(const std::string& name, const Model& part, const SurfaceMesh& surface);
  // A shell on the triangles of `surface` (need not be closed), one frame per vertex.
  int add_shell(const std::string& name, const SurfaceMesh& surface, const ShellProperties& properties);
  // A rigid body: mass, centre and inertia of the closed surface with this density
  // (model/mass_properties.hpp), one frame at the centre of mass.
  int add_rigid(const std::string& name, const SurfaceMesh& surface, double density);

  // Frames of object a within distance of b's surface are shared with b (see above). b must not
  // be rigid (use attach). Returns the number of frames of a merged.
  int share(int a, int b, double distance);
  // Frames of object a within distance of rigid body b's surface follow b. Returns their number.
  int attach(int a, int b, double distance);

  // Fixes all six DOFs of the object's frames whose rest position satisfies inside(x, y, z).
  template <class Predicate>
  int fix(int object, Predicate inside) {
    int count = 0;
    for (int f : m_objects.at(object).frames) {
      const double* x = &m_positions[3 * f];
      if (!inside(x[0], x[1], x[2])) continue;
      ++count;
      for (int k = 0; k < kFrameDofs; ++k) m_fixed[kFrameDofs * f + k] = 1;
    }
    return count;
  }

  int object_count() const { return static_cast<int>(m_objects.size()); }
  int find(const std::string& name) const;  // -1 when absent
  const ObjectInfo& object(int index) const { return m_objects.at(index); }

  // The coupled model: merged frames removed and indices compacted, reverse table, lumped masses
  // (samples, shells, rigid bodies), validated.
  Model build() const;

 private:
  struct Part {
    std::vector<double> sample_positions, volumes;
    std::vector<int> materials, offsets, frames;
    std::vector<std::uint8_t> rotation_stabilised;
    std::vector<double> weights, gradients;
  };
  int add_frames(const double* positions, int count);
  int resolve(int frame) const;

  std::vector<double> m_positions;      // [N][3] all frames ever added
  std::vector<int> m_alias;             // [N] -1 or the frame it was merged into
  std::vector<int> m_parent;            // [N] -1 or the rigid frame it follows
  std::vector<std::uint8_t> m_fixed;    // [N][6]
  std::vector<double> m_point_masses;   // [N] rigid bodies
  std::vector<double> m_inertias;       // [N][9] rigid bodies
  std::vector<Material> m_materials;
  std::vector<Part> m_parts;            // samples of tissues (frame indices global, before aliasing)
  std::vector<Shell> m_shells;          // triangles with global frame indices, before aliasing
  std::vector<ObjectInfo> m_objects;
};

// Shortest distance from p to the triangle (a, b, c) (Ericson, Real-Time Collision Detection 5.1.5).
double point_triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);
// Shortest distance from p to a surface mesh (every triangle; meshes here are small).
double point_surface_distance(const Vec3& p, const std::vector<double>& vertices, const std::vector<int>& triangles);

}  // namespace fascia
