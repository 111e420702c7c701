#include "model/assembly.hpp"

#include "mechanics/shell.hpp"
#include "model/mass_properties.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace fascia {

double point_triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return norm(ap);
  const Vec3 bp = p - b;
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return norm(bp);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return norm(p - (a + (d1 / (d1 - d3)) * ab));
  const Vec3 cp = p - c;
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return norm(cp);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return norm(p - (a + (d2 / (d2 - d6)) * ac));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return norm(p - (b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b)));
  const double denom = 1 / (va + vb + vc);
  return norm(p - (a + (vb * denom) * ab + (vc * denom) * ac));
}

double point_surface_distance(const Vec3& p, const std::vector<double>& vertices, const std::vector<int>& triangles) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t t = 0; t + 2 < triangles.size(); t += 3)
    best = std::min(best, point_triangle_distance(p, load3(&vertices[3 * triangles[t]]),
                                                  load3(&vertices[3 * triangles[t + 1]]),
                                                  load3(&vertices[3 * triangles[t + 2]])));
  return best;
}

int ModelBuilder::add_frames(const double* positions, int count) {
  const int first = static_cast<int>(m_alias.size());
  m_positions.insert(m_positions.end(), positions, positions + 3 * count);
  m_alias.resize(first + count, -1);
  m_parent.resize(first + count, -1);
  m_fixed.resize(kFrameDofs * (first + count), 0);
  m_point_masses.resize(first + count, 0.0);
  m_inertias.resize(9 * (first + count), 0.0);
  return first;
}

int ModelBuilder::resolve(int frame) const {
  while (m_alias[frame] >= 0) frame = m_alias[frame];
  return frame;
}

int ModelBuilder::find(const std::string& name) const {
  for (int k = 0; k < object_count(); ++k)
    if (m_objects[k].name == name) return k;
  return -1;
}

int ModelBuilder::add_tissue(const std::string& name, const Model& part, const SurfaceMesh& surface) {
  const int first = add_frames(part.frame_rest_positions.data(), part.frame_count());
  for (size_t k = 0; k < part.fixed_dofs.size(); ++k) m_fixed[kFrameDofs * first + k] = part.fixed_dofs[k];
  Part p;
  p.sample_positions = part.samples.rest_positions;
  p.volumes = part.samples.volumes;
  p.rotation_stabilised = part.samples.rotation_stabilised;
  p.rotation_stabilised.resize(p.volumes.size(), 0);
  const int material_base = static_cast<int>(m_materials.size());
  m_materials.insert(m_materials.end(), part.materials.begin(), part.materials.end());
  for (int m : part.samples.materials) p.materials.push_back(material_base + m);
  p.offsets = part.neighbours.offsets;
  for (int f : part.neighbours.frames) p.frames.push_back(first + f);
  p.weights = part.neighbours.weights;
  p.gradients = part.neighbours.weight_gradients;
  m_parts.push_back(std::move(p));
  ObjectInfo info;
  info.name = name;
  info.kind = ObjectKind::tissue;
  for (int i = 0; i < part.frame_count(); ++i) info.frames.push_back(first + i);
  info.surface_vertices = surface.vertices;
  info.surface_triangles = surface.triangles;
  m_objects.push_back(std::move(info));
  return object_count() - 1;
}

int ModelBuilder::add_shell(const std::string& name, const SurfaceMesh& surface, const ShellProperties& properties) {
  const int first = add_frames(surface.vertices.data(), surface.vertex_count());
  Shell shell;
  shell.thickness = properties.thickness;
  shell.young = properties.young;
  shell.poisson = properties.poisson;
  shell.density = properties.density;
  for (int v : surface.triangles) shell.triangles.push_back(first + v);
  m_shells.push_back(std::move(shell));
  ObjectInfo info;
  info.name = name;
  info.kind = ObjectKind::shell;
  for (int i = 0; i < surface.vertex_count(); ++i) info.frames.push_back(first + i);
  info.surface_vertices = surface.vertices;
  info.surface_triangles = surface.triangles;
  m_objects.push_back(std::move(info));
  return object_count() - 1;
}

int ModelBuilder::add_rigid(const std::string& name, const SurfaceMesh& surface, double density) {
  const MassProperties mp = mass_properties(surface, density);
  const double c[3] = {mp.centre.x, mp.centre.y, mp.centre.z};
  const int frame = add_frames(c, 1);
  m_point_masses[frame] = mp.mass;
  store_mat3(&m_inertias[9 * frame], mp.inertia);
  ObjectInfo info;
  info.name = name;
  info.kind = ObjectKind::rigid;
  info.frames = {frame};
  info.surface_vertices = surface.vertices;
  info.surface_triangles = surface.triangles;
  m_objects.push_back(std::move(info));
  return object_count() - 1;
}

int ModelBuilder::share(int a, int b, double distance) {
  const ObjectInfo& A = m_objects.at(a);
  const ObjectInfo& B = m_objects.at(b);
  if (B.kind == ObjectKind::rigid || A.kind == ObjectKind::rigid)
    throw std::invalid_argument("share: '" + (B.kind == ObjectKind::rigid ? B.name : A.name) +
                                "' is a rigid body; attach frames to it instead");
  std::vector<int> targets;
  for (int f : B.frames) targets.push_back(resolve(f));
  int merged = 0;
  for (int f : A.frames) {
    if (m_alias[f] >= 0 || m_parent[f] >= 0) continue;
    const Vec3 x = load3(&m_positions[3 * f]);
    if (point_surface_distance(x, B.surface_vertices, B.surface_triangles) > distance) continue;
    int best = -1;
    double best_d = std::numeric_limits<double>::infinity();
    for (int g : targets) {
      if (g == f) continue;
      const double d = norm(load3(&m_positions[3 * g]) - x);
      if (d < best_d) best_d = d, best = g;
    }
    if (best < 0) continue;
    m_alias[f] = best;
    ++merged;
  }
  return merged;
}

int ModelBuilder::attach(int a, int b, double distance) {
  const ObjectInfo& A = m_objects.at(a);
  const ObjectInfo& B = m_objects.at(b);
  if (B.kind != ObjectKind::rigid) throw std::invalid_argument("attach: '" + B.name + "' is not a rigid body");
  const int body = B.frames.front();
  int count = 0;
  for (int f : A.frames) {
    if (m_alias[f] >= 0 || f == body) continue;
    if (point_surface_distance(load3(&m_positions[3 * f]), B.surface_vertices, B.surface_triangles) > distance) continue;
    m_parent[f] = body;
    ++count;
  }
  return count;
}

Model ModelBuilder::build() const {
  const int total = static_cast<int>(m_alias.size());
  std::vector<int> index(total, -1);
  Model model;
  for (int f = 0; f < total; ++f) {
    if (m_alias[f] >= 0) continue;
    index[f] = model.frame_count();
    model.frame_rest_positions.insert(model.frame_rest_positions.end(), &m_positions[3 * f], &m_positions[3 * f + 3]);
  }
  auto global = [&](int f) { return index[resolve(f)]; };
  const int n = model.frame_count();
  model.fixed_dofs.assign(kFrameDofs * n, 0);
  model.rigid_parents.assign(n, -1);
  for (int f = 0; f < total; ++f) {
    const int g = global(f);
    for (int k = 0; k < kFrameDofs; ++k) model.fixed_dofs[kFrameDofs * g + k] |= m_fixed[kFrameDofs * f + k];
    if (m_parent[f] >= 0) model.rigid_parents[g] = global(m_parent[f]);
  }
  if (std::all_of(model.rigid_parents.begin(), model.rigid_parents.end(), [](int p) { return p < 0; }))
    model.rigid_parents.clear();

  // Samples; rest offsets re-based on the (possibly merged) frame: l = p_s - x_g (eq. 2).
  model.materials = m_materials;
  NeighbourTable& nb = model.neighbours;
  nb.offsets.push_back(0);
  for (const Part& part : m_parts) {
    const int s_count = static_cast<int>(part.volumes.size());
    for (int s = 0; s < s_count; ++s) {
      model.samples.rest_positions.insert(model.samples.rest_positions.end(), &part.sample_positions[3 * s],
                                          &part.sample_positions[3 * s + 3]);
      model.samples.volumes.push_back(part.volumes[s]);
      model.samples.materials.push_back(part.materials[s]);
      model.samples.rotation_stabilised.push_back(part.rotation_stabilised[s]);
      const int begin = static_cast<int>(nb.frames.size());
      for (int p = part.offsets[s]; p < part.offsets[s + 1]; ++p) {
        const int f = part.frames[p], g = global(f);
        const Vec3 l = load3(&part.sample_positions[3 * s]) - load3(&model.frame_rest_positions[3 * g]);
        int slot = -1;
        for (int q = begin; q < static_cast<int>(nb.frames.size()); ++q)
          if (nb.frames[q] == g) slot = q;
        if (slot >= 0) {  // two frames of the sample merged into one
          nb.weights[slot] += part.weights[p];
          for (int k = 0; k < 3; ++k) nb.weight_gradients[3 * slot + k] += part.gradients[3 * p + k];
          continue;
        }
        nb.frames.push_back(g);
        nb.weights.push_back(part.weights[p]);
        nb.weight_gradients.insert(nb.weight_gradients.end(), &part.gradients[3 * p], &part.gradients[3 * p + 3]);
        nb.rest_offsets.insert(nb.rest_offsets.end(), {l.x, l.y, l.z});
      }
      nb.offsets.push_back(static_cast<int>(nb.frames.size()));
    }
  }
  build_reverse_table(model);
  compute_frame_inertia(model);
  model.frame_point_masses.assign(n, 0.0);
  for (int f = 0; f < total; ++f) {
    if (m_point_masses[f] == 0) continue;
    const int g = global(f);
    model.frame_masses[g] += m_point_masses[f];
    model.frame_point_masses[g] += m_point_masses[f];
    for (int k = 0; k < 9; ++k) model.frame_inertias[9 * g + k] += m_inertias[9 * f + k];
  }
  for (const Shell& s : m_shells) {
    Shell shell = s;
    for (int& v : shell.triangles) v = global(v);
    add_shell_masses(model, shell);
    model.shells.push_back(std::move(shell));
  }
  for (const ObjectInfo& o : m_objects) {
    ObjectInfo info = o;
    for (int& f : info.frames) f = global(f);
    model.objects.push_back(std::move(info));
  }
  validate(model);
  return model;
}

}  // namespace fascia
