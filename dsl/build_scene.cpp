#include "dsl/build_scene.hpp"

#include "discretise/mesh_based.hpp"
#include "discretise/label_image.hpp"
#include "discretise/level_set.hpp"
#include "discretise/meshless.hpp"
#include "discretise/voxel_domain.hpp"
#include "discretise/surface_mesh.hpp"
#include "shape/meshless_shape.hpp"
#include "io/boundary_surface.hpp"
#include "io/volume_mesh_io.hpp"
#include "model/assembly.hpp"

#include <cstdio>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <ios>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace fascia::dsl {

namespace {

namespace fs = std::filesystem;

Vec3 to_vec3(const Vec3d& v) { return Vec3{v[0], v[1], v[2]}; }

// A nonzero vector orthogonal to the nonzero v: v x the axis along its smallest component.
Vec3 orthogonal_to(const Vec3& v) {
  const double ax = std::abs(v.x), ay = std::abs(v.y), az = std::abs(v.z);
  const Vec3 axis = ax <= ay && ax <= az ? Vec3{1, 0, 0} : ay <= az ? Vec3{0, 1, 0} : Vec3{0, 0, 1};
  return cross(v, axis);
}

Vec3d frame_position(const Model& model, int i) {
  const double* x = &model.frame_rest_positions[3 * static_cast<std::size_t>(i)];
  return {x[0], x[1], x[2]};
}

// Tolerance for region tests: points on a region's border count as inside despite round-off.
double region_tolerance(const Model& model) {
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (int i = 0; i < model.frame_count(); ++i)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], model.frame_rest_positions[3 * static_cast<std::size_t>(i) + static_cast<std::size_t>(k)]);
      hi[k] = std::max(hi[k], model.frame_rest_positions[3 * static_cast<std::size_t>(i) + static_cast<std::size_t>(k)]);
    }
  const double diag = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                (hi[2] - lo[2]) * (hi[2] - lo[2]));
  return 1e-9 * std::max(diag, 1e-12);
}

// Frames of the region among `frames` (global indices of one object's frames; ids index that
// list); reports ids out of range and empty selections.
std::vector<int> select_frames(const Model& model, const std::vector<int>& frames, const RegionSpec& region,
                               const std::string& object, Diagnostics& diagnostics) {
  std::vector<int> out;
  const int count = static_cast<int>(frames.size());
  if (region.kind == RegionSpec::Kind::ids) {
    for (int id : region.ids) {
      if (id < 0 || id >= count) {
        diagnostics.error(region.where, "frame id " + std::to_string(id) + " is out of range: object '" + object +
                                            "' has " + std::to_string(count) + " frames (0.." +
                                            std::to_string(count - 1) + ")");
        return {};
      }
      out.push_back(frames[static_cast<std::size_t>(id)]);
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }
  const double tol = region_tolerance(model);
  for (int i : frames)
    if (region.contains(frame_position(model, i), tol)) out.push_back(i);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  if (out.empty())
    diagnostics.error(region.where, "region selects no frames of object '" + object +
                                        "' (frames are tested at their rest positions, world axes, metres)");
  return out;
}

std::string metres(double d) {
  char text[64];
  std::snprintf(text, sizeof text, "%g mm", d * 1e3);
  return text;
}

std::string count_text(double n) {
  char text[64];
  std::snprintf(text, sizeof text, n < 1e6 ? "%.0f" : "%.2g", n);
  return text;
}

// The memory the objects built so far are estimated to need, against the limit.
struct MemoryBudget {
  double limit = 0;      // bytes
  double committed = 0;  // bytes, objects admitted so far

  // Admits an object, or reports at `where` what it asks for, the estimate and the likely cause.
  bool admit(const ObjectSpec& o, const ObjectEstimate& e, const std::string& what, const Location& where,
             Diagnostics& diagnostics) {
    const double total = committed + e.bytes;
    const bool counts_fit = e.samples < std::numeric_limits<int>::max() && e.frames < std::numeric_limits<int>::max();
    if (total <= limit && counts_fit) {
      committed = total;
      return true;
    }
    std::string message = "object '" + o.name + "': " + what + " need about " + bytes_text(e.bytes);
    if (committed > 0) message += " (" + bytes_text(total) + " with the objects before it)";
    message += total > limit ? ", more than --max-memory " + bytes_text(limit)
                             : ", and more than the 2147483647 frames or samples a model can index";
    message += e.cause.empty() ? "; use a coarser resolution or a larger --max-memory" : "; " + e.cause;
    diagnostics.error(where, message, ExitCode::too_large);
    return false;
  }
};

// A mesh file is refused before it is read when reading it alone would not fit.
bool admit_file(const ObjectSpec& o, const Located<std::string>& file, MemoryBudget& budget, Diagnostics& diagnostics) {
  std::error_code ec;
  const auto size = fs::file_size(file.value, ec);
  if (ec) return true;  // not a regular file: the reader reports it
  ObjectEstimate e;
  e.bytes = mesh_file_bytes(static_cast<double>(size));
  const MemoryBudget before = budget;
  if (!budget.admit(o, e, "reading '" + file.value + "' (" + bytes_text(static_cast<double>(size)) + ") would",
                    file.where, diagnostics))
    return false;
  budget = before;  // what the file becomes is estimated once read
  return true;
}

// Admits the meshless discretisation of `surface` with `options` into the budget (its estimate,
// resource_estimate.hpp), reported at `where` (the scene's sample_spacing).
bool admit_meshless(const ObjectSpec& o, const SurfaceMesh& surface, const MeshlessOptions& options,
                    const Location& where, MemoryBudget& budget, Diagnostics& diagnostics) {
  const ObjectEstimate estimate = estimate_meshless(surface, options);
  return budget.admit(o, estimate,
                      "about " + count_text(estimate.samples) + " samples (sample_spacing " +
                          metres(options.sample_spacing) + ") and " + count_text(estimate.frames) +
                          " frames (frame_spacing " + metres(options.frame_spacing) + ")",
                      where, diagnostics);
}

// The object's transform (scale, rotation, translation) applied to vertices [V][3] (m) in place.
void transform_vertices(const TransformSpec& transform, std::vector<double>& vertices) {
  for (std::size_t v = 0; v + 2 < vertices.size(); v += 3) {
    const Vec3d p = transform.apply({vertices[v], vertices[v + 1], vertices[v + 2]});
    for (int k = 0; k < 3; ++k) vertices[v + k] = p[k];
  }
}

VolumeMesh object_mesh(const ObjectSpec& o, Diagnostics& diagnostics) {
  VolumeMesh mesh;
  if (o.box) {
    const BoxSpec& b = *o.box;
    const Vec3 lo = to_vec3(b.min.value), hi = to_vec3(b.max.value);
    const auto& n = b.cells.value;
    mesh = b.elements.value == "tet" ? box_tet_mesh(lo, hi, n[0], n[1], n[2]) : box_hex_mesh(lo, hi, n[0], n[1], n[2]);
  } else if (o.mesh) {
    try {
      mesh = read_volume_mesh(o.mesh->value);
    } catch (const MeshFormatError& e) {
      diagnostics.error(o.mesh->where, std::string("mesh: ") + e.what(), ExitCode::bad_data);
      return {};
    } catch (const std::ios_base::failure& e) {
      diagnostics.error(o.mesh->where, std::string("mesh: ") + e.what(), ExitCode::missing_input);
      return {};
    }
  }
  // Geometry transform: scale, rotate, translate (the box too, so that it can be placed freely).
  transform_vertices(o.transform, mesh.vertices);
  return mesh;
}

double face_area(const VolumeMesh& mesh, const BoundarySurface& s, int f, Vec3d& centre) {
  const int k = s.nodes_per_face;
  auto vertex = [&](int j) {
    const int v = s.vertices[static_cast<std::size_t>(s.faces[static_cast<std::size_t>(f * k + j)])];
    const double* x = &mesh.vertices[3 * static_cast<std::size_t>(v)];
    return Vec3d{x[0], x[1], x[2]};
  };
  centre = {0, 0, 0};
  for (int j = 0; j < k; ++j)
    for (int c = 0; c < 3; ++c) centre[static_cast<std::size_t>(c)] += vertex(j)[static_cast<std::size_t>(c)] / k;
  // Area of a planar polygon: half the norm of the sum of cross products around the centre.
  double n[3] = {0, 0, 0};
  for (int j = 0; j < k; ++j) {
    const Vec3d a = vertex(j), b = vertex((j + 1) % k);
    const double u[3] = {a[0] - centre[0], a[1] - centre[1], a[2] - centre[2]};
    const double w[3] = {b[0] - centre[0], b[1] - centre[1], b[2] - centre[2]};
    n[0] += u[1] * w[2] - u[2] * w[1];
    n[1] += u[2] * w[0] - u[0] * w[2];
    n[2] += u[0] * w[1] - u[1] * w[0];
  }
  return 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
}

// One object before assembly: its own discretisation (tissues), the surface used for couplings,
// surface forces and output, in world axes at rest.
struct ObjectPart {
  const ObjectSpec* spec = nullptr;
  Model part;                      // tissues: frames and samples of this object alone
  bool mesh_based = false, meshless = false;
  VolumeMesh mesh;                 // mesh-based tissue
  BoundarySurface boundary;        // mesh-based tissue
  SurfaceMesh surface;             // triangles (mesh-based: over all mesh vertices)
  MeshlessShape shape;             // meshless tissue: its frames' shape functions
  double density = 0;              // rigid body
  ShellProperties shell;           // shell
  std::string discretisation;
  std::optional<MeshlessStatistics> statistics;  // meshless tissue: what the build reports
  std::vector<int> frames;         // after assembly: global index of each of the object's frames
};

Material scene_material(const SceneSpec& scene, const ObjectSpec& o) {
  const MaterialSpec* m = scene.material(o.material->value);
  if (m->law.value == "hgo") {
    const FibresSpec& f = *m->fibres;
    Fibres fibres{f.k1.value, f.k2.value, f.dispersion.value, Vec3{1, 0, 0}};
    // Without a material direction the object gives every sample its own (place_fibres; the
    // scene checks ensure it).
    if (f.direction) fibres.direction = Vec3{f.direction->value[0], f.direction->value[1], f.direction->value[2]};
    fibres.families = f.families.value;
    if (f.angle) fibres.angle = f.angle->value;
    if (f.plane) fibres.plane = to_vec3(f.plane->value);
    // Without a material direction place_fibres sets each sample's; the material's own direction
    // must still form a valid pair with the plane, so it is taken orthogonal to the plane.
    if (!f.direction && f.plane) fibres.direction = orthogonal_to(fibres.plane);
    const HgoFormulation formulation = m->formulation && m->formulation->value == "uncoupled"
                                           ? HgoFormulation::uncoupled
                                           : HgoFormulation::coupled;
    return make_hgo_material(m->young.value, m->poisson.value, m->density.value, fibres, formulation);
  }
  const MaterialLaw law = m->law.value == "neo_hookean" ? MaterialLaw::neo_hookean : MaterialLaw::stvk;
  return make_material(law, m->young.value, m->poisson.value, m->density.value);
}

// The object's fibre directions (ObjectSpec::fibres) on the samples of its model `model`: one
// direction for all, or per sample (fibre regions; `from`, the gradient of that organ's
// distance field `from`), where each sample gets its own entry of model.materials.
void place_fibres(const ObjectSpec& o, Model& model, const LevelSet* from, Diagnostics& diagnostics) {
  if (!o.fibres) return;
  const ObjectFibresSpec& f = *o.fibres;
  // with_fibre_direction refuses, for two families, a direction along their plane vector.
  const auto set_direction = [&](Material& m, const Vec3& d, const Location& where, const std::string& what) {
    try {
      m = with_fibre_direction(m, d);
      return true;
    } catch (const std::invalid_argument& e) {
      diagnostics.error(where, what + ": " + e.what() + " (fibres.plane of material '" + o.material->value +
                                   "' must span the two families' plane with it)");
      return false;
    }
  };
  if (f.direction) {
    for (Material& m : model.materials)
      if (!set_direction(m, to_vec3(f.direction->value), f.direction->where, "fibres.direction")) return;
    return;
  }
  const std::vector<Material> shared = model.materials;
  const int S = model.sample_count();
  model.materials.resize(static_cast<std::size_t>(S));
  for (int s = 0; s < S; ++s) {
    const std::size_t si = static_cast<std::size_t>(s);
    const Vec3 p = load3(&model.samples.rest_positions[3 * si]);
    const std::string at = " at the sample at (" + metres(p.x) + ", " + metres(p.y) + ", " + metres(p.z) + ")";
    Material m = shared[static_cast<std::size_t>(model.samples.materials[si])];
    if (from) {
      const Vec3 g = from->gradient(p);
      if (!(norm(g) > 1e-6)) {
        diagnostics.error(f.from->where, "fibres.from: the distance to '" + f.from->value + "' has no gradient" + at);
        return;
      }
      if (!set_direction(m, g, f.from->where, "fibres.from" + at)) return;
    } else {
      for (const ObjectFibresSpec::Region& r : f.regions)
        if (r.region.contains({p.x, p.y, p.z}, 0)) {
          if (!set_direction(m, to_vec3(r.direction.value), r.direction.where, "fibres.regions[].direction"))
            return;
          break;
        }
    }
    model.materials[si] = m;
    model.samples.materials[si] = s;
  }
}

bool read_transformed_surface(const ObjectSpec& o, SurfaceMesh& surface, MemoryBudget& budget,
                              Diagnostics& diagnostics) {
  if (!admit_file(o, *o.surface, budget, diagnostics)) return false;
  try {
    surface = read_surface_mesh(o.surface->value);
  } catch (const std::ios_base::failure& e) {
    diagnostics.error(o.surface->where, std::string("surface: ") + e.what(), ExitCode::missing_input);
    return false;
  } catch (const std::exception& e) {
    diagnostics.error(o.surface->where, std::string("surface: ") + e.what(), ExitCode::bad_data);
    return false;
  }
  transform_vertices(o.transform, surface.vertices);
  return true;
}

// A mesh-based tissue: volume mesh, discretisation, boundary surface (quads split in triangles).
bool make_mesh_tissue(const SceneSpec& scene, ObjectPart& part, MemoryBudget& budget, Diagnostics& diagnostics) {
  const ObjectSpec& o = *part.spec;
  const int q = o.quadrature.value;
  if (o.box) {
    // The generated grid is estimated from the cell counts before it exists.
    const BoxSpec& b = *o.box;
    const bool tet = b.elements.value == "tet";
    double cells = 1, vertices = 1, extent = 0;
    for (std::size_t k = 0; k < 3; ++k) {
      cells *= b.cells.value[k];
      vertices *= b.cells.value[k] + 1.0;
      extent = std::max(extent, o.transform.scale * (b.max.value[k] - b.min.value[k]));
    }
    const ObjectEstimate e = estimate_mesh_based(tet ? 6 * cells : cells, tet ? 4 : 8, vertices,
                                                 tet ? (q == 1 ? 1 : 4) : (q == 0 ? 8 : q), extent);
    if (!budget.admit(o, e, "box cells [" + std::to_string(b.cells.value[0]) + ", " + std::to_string(b.cells.value[1]) +
                                ", " + std::to_string(b.cells.value[2]) + "] (" + count_text(e.samples) + " samples)",
                      b.cells.where, diagnostics))
      return false;
  } else if (o.mesh && !admit_file(o, *o.mesh, budget, diagnostics)) {
    return false;
  }
  part.mesh = object_mesh(o, diagnostics);
  if (!diagnostics.empty()) return false;
  const bool tet = part.mesh.type == CellType::tetrahedron;
  if (q != 0 && (tet ? (q != 1 && q != 4) : (q != 1 && q != 8 && q != 27))) {
    diagnostics.error(o.quadrature.where, std::string("quadrature ") + std::to_string(q) + " is not available for " +
                                              (tet ? "tetrahedra (use 1 or 4)" : "hexahedra (use 1, 8 or 27)"));
    return false;
  }
  if (o.mesh) {
    Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
    for (int v = 0; v < part.mesh.vertex_count(); ++v) {
      const Vec3 x = load3(&part.mesh.vertices[3 * static_cast<std::size_t>(v)]);
      lo = Vec3{std::min(lo.x, x.x), std::min(lo.y, x.y), std::min(lo.z, x.z)};
      hi = Vec3{std::max(hi.x, x.x), std::max(hi.y, x.y), std::max(hi.z, x.z)};
    }
    const ObjectEstimate e =
        estimate_mesh_based(part.mesh.cell_count(), part.mesh.nodes_per_cell(), part.mesh.vertex_count(),
                            tet ? (q == 1 ? 1 : 4) : (q == 0 ? 8 : q), std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z}));
    if (!budget.admit(o, e, std::to_string(part.mesh.cell_count()) + " cells (" + count_text(e.samples) + " samples)",
                      o.mesh->where, diagnostics))
      return false;
  }
  MeshDiscretisation options;
  options.quadrature = tet ? q : (q == 1 ? 1 : q == 27 ? 3 : q == 8 ? 2 : 0);
  try {
    part.part = build_mesh_model(part.mesh, scene_material(scene, o), options);
  } catch (const std::invalid_argument& e) {
    const Location where = o.mesh ? o.mesh->where : o.where;
    diagnostics.error(where, std::string("cannot discretise '") + o.name + "': " + e.what(),
                      o.mesh ? ExitCode::bad_data : ExitCode::bad_scene);
    return false;
  }
  if (o.lock_rotations) lock_rotations(part.part);
  part.mesh_based = true;
  part.boundary = boundary_surface(part.mesh);
  part.surface.vertices = part.mesh.vertices;
  const int k = part.boundary.nodes_per_face;
  for (int f = 0; f < part.boundary.face_count(); ++f) {
    auto v = [&](int j) {
      return part.boundary.vertices[static_cast<std::size_t>(part.boundary.faces[static_cast<std::size_t>(f * k + j)])];
    };
    for (int j = 1; j + 1 < k; ++j) part.surface.triangles.insert(part.surface.triangles.end(), {v(0), v(j), v(j + 1)});
  }
  part.discretisation = std::string("mesh-based, ") + std::to_string(part.mesh.cell_count()) +
                        (tet ? " tetrahedra" : " hexahedra");
  return true;
}

MeshlessOptions meshless_options(const MeshlessSpec& ml) {
  MeshlessOptions options;
  options.frame_spacing = ml.frame_spacing.value;
  options.sample_spacing = ml.sample_spacing.value;
  options.shape.support_neighbours = ml.neighbours.value;
  options.seed = static_cast<std::uint64_t>(ml.seed.value);
  options.thin_parts = ml.thin_parts.value == "stop" ? ThinParts::stop : ThinParts::repair;
  return options;
}

// A meshless tissue from the voxels of a label image: their level set on the lattice of spacing
// sample_spacing / 2, the model's volume scaled to voxel count x voxel volume, the boundary
// surface extracted from the level set.
bool make_image_tissue(const SceneSpec& scene, ObjectPart& part, MemoryBudget& budget, Diagnostics& diagnostics) {
  const ObjectSpec& o = *part.spec;
  const MeshlessSpec& ml = *o.meshless;
  const MeshlessOptions options = meshless_options(ml);
  if (!(options.sample_spacing < options.frame_spacing)) {
    diagnostics.error(ml.sample_spacing.where, "sample_spacing must be smaller than frame_spacing");
    return false;
  }
  LabelImage image;
  try {
    image = read_label_image(o.image->value);
  } catch (const LabelImageError& e) {
    diagnostics.error(o.image->where, std::string("image: ") + e.what(),
                      e.kind() == LabelImageError::Kind::missing_input ? ExitCode::missing_input : ExitCode::bad_data);
    return false;
  }
  const std::vector<int>& labels = o.label->value;
  for (int l : labels) {
    if (image.count({l}) > 0) continue;
    const std::vector<int> present = image.present();
    std::string list;
    for (std::size_t k = 0; k < present.size() && k < 20; ++k) list += (k ? ", " : "") + std::to_string(present[k]);
    if (present.size() > 20) list += ", ... (" + std::to_string(present.size()) + " labels)";
    diagnostics.error(o.label->where, "label " + std::to_string(l) + " is absent from '" + o.image->value +
                                          "' (labels present: " + list + ")");
    return false;
  }
  // The object's transform, composed with the image's index-to-world map.
  const Vec3d o0 = o.transform.apply({image.origin.x, image.origin.y, image.origin.z});
  Mat3 edges = image.index_to_world;
  for (int c = 0; c < 3; ++c) {
    const Vec3d e = o.transform.apply({image.origin.x + image.index_to_world.m[0][c],
                                       image.origin.y + image.index_to_world.m[1][c],
                                       image.origin.z + image.index_to_world.m[2][c]});
    for (int r = 0; r < 3; ++r) edges.m[r][c] = e[static_cast<std::size_t>(r)] - o0[static_cast<std::size_t>(r)];
  }
  image.index_to_world = edges;
  image.origin = to_vec3(o0);
  const double smoothing = o.smoothing ? o.smoothing->value : 0;
  if (smoothing > options.frame_spacing) {
    diagnostics.error(o.smoothing->where, "smoothing " + metres(smoothing) + " is wider than frame_spacing " +
                                              metres(options.frame_spacing) +
                                              ": it would erase shapes the frames resolve; at most frame_spacing");
    return false;
  }
  double smoothed = 0;  // the standard deviation realised on the lattice, m
  MeshlessBuild result;
  try {
    const double h = options.sample_spacing / 2;
    const int band = LevelSet::smoothing_band(smoothing, h);
    if (!budget.admit(o, estimate_label_level_set(image, labels, h, band),
                      "the level set of its voxels (a band of " + std::to_string(band) + " voxels of " + metres(h) +
                          " each side of their boundary) would",
                      ml.sample_spacing.where, diagnostics))
      return false;
    LevelSet level_set = LevelSet::from_labels(image, labels, h, band);
    if (smoothing > 0) {
      smoothed = level_set.smooth(smoothing);
      if (VoxelDomain(level_set).covered_count() == 0) {
        diagnostics.error(o.smoothing->where, "smoothing " + metres(smoothing) + " leaves nothing of '" + o.name +
                                                  "': its labels are thinner than that; use a smaller smoothing");
        return false;
      }
    }
    part.surface = level_set.surface();
    if (!admit_meshless(o, part.surface, options, ml.sample_spacing.where, budget, diagnostics))
      return false;
    result = build_meshless_model(VoxelDomain(level_set), part.surface, scene_material(scene, o), options);
  } catch (const std::exception& e) {
    diagnostics.error(ml.frame_spacing.where, "cannot discretise '" + o.name + "': " + e.what());
    return false;
  }
  part.part = std::move(result.model);
  if (o.lock_rotations) lock_rotations(part.part);
  part.meshless = true;
  part.shape = result.shape;
  std::string label_text;
  for (std::size_t k = 0; k < labels.size(); ++k) label_text += (k ? ", " : "") + std::to_string(labels[k]);
  part.discretisation = "meshless (" + ml.shape.value + ") from label " + label_text + " of a " +
                        std::to_string(image.size[0]) + " x " + std::to_string(image.size[1]) + " x " +
                        std::to_string(image.size[2]) + " image, " +
                        (smoothed > 0 ? "smoothed (standard deviation " + metres(smoothed) + "), " : std::string()) +
                        std::to_string(part.surface.triangle_count()) +
                        " boundary triangles, " + std::to_string(result.statistics.added_frames) +
                        " frames added in thin parts";
  // The masses follow the zero surface's enclosed volume (consistent integration needs the
  // volume its boundary rule encloses): say how far it is from the voxels'.
  const double voxel_volume = static_cast<double>(image.count(labels)) * image.voxel_volume();
  std::ostringstream volumes;
  volumes.precision(4);
  volumes << "; the labelled voxels hold " << voxel_volume << " m^3, the level set's zero surface encloses "
          << result.statistics.surface_volume << " m^3 ("
          << std::showpos << 100 * (result.statistics.surface_volume / voxel_volume - 1) << " %)";
  part.discretisation += volumes.str();
  part.statistics = result.statistics;
  return true;
}

// A meshless tissue filling the space within `within` of two organs' rest surfaces, outside
// both (LevelSet::between on the lattice of spacing sample_spacing / 2).
bool make_between_tissue(const SceneSpec& scene, std::vector<ObjectPart>& parts, ObjectPart& part, MemoryBudget& budget,
                         Diagnostics& diagnostics) {
  const ObjectSpec& o = *part.spec;
  const MeshlessSpec& ml = *o.meshless;
  const MeshlessOptions options = meshless_options(ml);
  if (!(options.sample_spacing < options.frame_spacing)) {
    diagnostics.error(ml.sample_spacing.where, "sample_spacing must be smaller than frame_spacing");
    return false;
  }
  const double h = options.sample_spacing / 2, within = o.within->value;
  const int band = static_cast<int>(std::ceil(within / h)) + 3;
  std::vector<LevelSet> organs;
  for (const Located<std::string>& name : o.between) {
    const ObjectPart* organ = nullptr;
    for (const ObjectPart& p : parts)
      if (p.spec->name == name.value) organ = &p;
    if (organ == nullptr || organ == &part) {
      diagnostics.error(name.where, organ ? "a tissue cannot lie between itself and another object"
                                          : "unknown object '" + name.value + "' in between");
      return false;
    }
    if (!organ->spec->between.empty() || organ->spec->kind.value == "shell") {
      diagnostics.error(name.where, "'" + name.value + "' is " +
                                        (organ->spec->kind.value == "shell" ? std::string("a shell, whose surface encloses no volume")
                                                                            : std::string("itself a tissue between organs")) +
                                        "; 'between' takes tissues or rigid bodies");
      return false;
    }
    if (!budget.admit(o, estimate_level_set(organ->surface, h, band),
                      "the level set of '" + name.value + "' (a band of " + std::to_string(band) + " voxels of " +
                          metres(h) + " each side of its surface) would",
                      name.where, diagnostics))
      return false;
    try {
      organs.push_back(LevelSet::from_surface(organ->surface, h, band));
    } catch (const std::exception& e) {
      diagnostics.error(name.where, "cannot voxelise '" + name.value + "': " + e.what());
      return false;
    }
  }
  MeshlessBuild result;
  try {
    std::function<double(const Vec3&)> region;
    if (o.region)
      region = [&o](const Vec3& x) { return o.region->signed_distance(Vec3d{x.x, x.y, x.z}); };
    const LevelSet level_set = LevelSet::between(organs[0], organs[1], within, region);
    part.surface = level_set.surface();
    if (!admit_meshless(o, part.surface, options, ml.sample_spacing.where, budget, diagnostics))
      return false;
    const VoxelDomain domain(level_set);
    result = build_meshless_model(domain, part.surface, scene_material(scene, o), options);
    const LevelSet* from = nullptr;
    if (o.fibres && o.fibres->from) from = &organs[o.fibres->from->value == o.between[0].value ? 0 : 1];
    place_fibres(o, result.model, from, diagnostics);
  } catch (const std::exception& e) {
    diagnostics.error(o.within->where, "cannot build the tissue between '" + o.between[0].value + "' and '" +
                                           o.between[1].value + "': " + e.what());
    return false;
  }
  part.part = std::move(result.model);
  if (o.lock_rotations) lock_rotations(part.part);
  part.meshless = true;
  part.shape = result.shape;
  part.discretisation = "meshless (" + ml.shape.value + ") between '" + o.between[0].value + "' and '" +
                        o.between[1].value + "' within " + metres(within) + (o.region ? " in its region" : "") + ", " +
                        std::to_string(part.surface.triangle_count()) + " boundary triangles";
  part.statistics = result.statistics;
  return true;
}

bool make_meshless_tissue(const SceneSpec& scene, ObjectPart& part, MemoryBudget& budget, Diagnostics& diagnostics) {
  const ObjectSpec& o = *part.spec;
  if (!read_transformed_surface(o, part.surface, budget, diagnostics)) return false;
  const MeshlessSpec& ml = *o.meshless;
  MeshlessOptions options = meshless_options(ml);
  if (!(options.sample_spacing < options.frame_spacing)) {
    diagnostics.error(ml.sample_spacing.where, "sample_spacing must be smaller than frame_spacing");
    return false;
  }
  Vec3 lo, hi;
  surface_bounds(part.surface, lo, hi);
  const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  if (!(options.frame_spacing < extent)) {
    diagnostics.error(ml.frame_spacing.where, "frame_spacing " + metres(options.frame_spacing) +
                                                  " is not smaller than the object, which is " + metres(extent) +
                                                  " across: it would hold a single frame at most");
    return false;
  }
  if (!admit_meshless(o, part.surface, options, ml.sample_spacing.where, budget, diagnostics))
    return false;
  MeshlessBuild result;
  try {
    result = build_meshless_model(part.surface, scene_material(scene, o), options);
  } catch (const std::exception& e) {
    diagnostics.error(ml.frame_spacing.where, "cannot discretise '" + o.name + "': " + e.what());
    return false;
  }
  part.part = std::move(result.model);
  if (o.lock_rotations) lock_rotations(part.part);
  part.meshless = true;
  part.shape = result.shape;
  part.discretisation = "meshless (" + ml.shape.value + "), " + std::to_string(part.surface.triangle_count()) +
                        " surface triangles, " + std::to_string(result.statistics.added_frames) +
                        " frames added in thin parts";
  part.statistics = result.statistics;
  return true;
}

// Shape-function table of `points` over one object's own frames, re-indexed to the assembled
// model's frames with the rest offsets re-based on them (l = p - x_g, as ModelBuilder does).
NeighbourTable object_table(const ObjectPart& part, const Model& model, const std::vector<double>& points) {
  NeighbourTable t = build_meshless_table(part.shape, points).neighbours;
  for (std::size_t q = 0; q + 1 < t.offsets.size(); ++q)
    for (int pr = t.offsets[q]; pr < t.offsets[q + 1]; ++pr) {
      const std::size_t r = static_cast<std::size_t>(pr);
      const int g = part.frames[static_cast<std::size_t>(t.frames[r])];
      t.frames[r] = g;
      for (std::size_t k = 0; k < 3; ++k)
        t.rest_offsets[3 * r + k] = points[3 * q + k] - model.frame_rest_positions[3 * static_cast<std::size_t>(g) + k];
    }
  return t;
}

BuiltObject output_object(const ObjectPart& part, const Model& model) {
  const ObjectSpec& o = *part.spec;
  BuiltObject object;
  object.name = o.name;
  object.surface.name = o.name;
  object.discretisation = part.discretisation;
  object.meshless = part.statistics;
  if (part.mesh_based) {
    object.surface.nodes_per_face = part.boundary.nodes_per_face;
    object.surface.faces = part.boundary.faces;
    for (int v : part.boundary.vertices) object.surface.vertex_frames.push_back(part.frames[static_cast<std::size_t>(v)]);
    return object;
  }
  object.surface.nodes_per_face = 3;
  object.surface.faces = part.surface.triangles;
  const int V = part.surface.vertex_count();
  if (o.kind.value == "shell") {  // a frame per vertex
    object.surface.vertex_frames = part.frames;
    return object;
  }
  object.surface.vertex_frames.assign(static_cast<std::size_t>(V), -1);
  object.skinned = true;
  if (part.meshless) {
    object.skin = object_table(part, model, part.surface.vertices);
    return object;
  }
  // Rigid: x = x_b + R_b (v - c), one neighbour of weight 1 per vertex.
  const int g = part.frames.front();
  NeighbourTable& t = object.skin;
  t.offsets.push_back(0);
  for (int v = 0; v < V; ++v) {
    t.frames.push_back(g);
    t.weights.push_back(1.0);
    for (std::size_t k = 0; k < 3; ++k) {
      t.weight_gradients.push_back(0.0);
      t.rest_offsets.push_back(part.surface.vertices[3 * static_cast<std::size_t>(v) + k] -
                               model.frame_rest_positions[3 * static_cast<std::size_t>(g) + k]);
    }
    t.offsets.push_back(v + 1);
  }
  return object;
}

void finish_scene(const SceneSpec& scene, std::vector<ObjectPart>& parts, BuiltScene& built, Diagnostics& diagnostics);

}  // namespace

DiscretisationStats discretisation_stats(const Model& model) {
  DiscretisationStats s;
  s.frames = model.frame_count();
  s.samples = model.sample_count();
  s.dofs = model.nominal_dof_count();
  s.volume = model.total_volume();
  s.mass = model.total_mass();
  s.neighbours_min = s.samples ? std::numeric_limits<int>::max() : 0;
  for (int k = 0; k < s.samples; ++k) {
    const int n = model.neighbours.offsets[static_cast<std::size_t>(k) + 1] - model.neighbours.offsets[static_cast<std::size_t>(k)];
    s.neighbours_min = std::min(s.neighbours_min, n);
    s.neighbours_max = std::max(s.neighbours_max, n);
  }
  s.neighbours_mean = s.samples ? static_cast<double>(model.pair_count()) / s.samples : 0.0;
  for (int i = 0; i < s.frames; ++i) {
    bool fixed = false;
    for (int k = 0; k < kFrameDofs && static_cast<std::size_t>(kFrameDofs * i + k) < model.fixed_dofs.size(); ++k)
      fixed = fixed || (model.fixed_dofs[static_cast<std::size_t>(kFrameDofs * i + k)] && k < 3);
    s.fixed_frames += fixed ? 1 : 0;
  }
  return s;
}

BuiltScene build_scene(const SceneSpec& scene, const ResourceLimits& limits) {
  Diagnostics diagnostics;
  BuiltScene built;
  MemoryBudget budget;
  budget.limit = limits.max_memory > 0 ? limits.max_memory : machine_memory();
  if (scene.objects.empty()) {
    diagnostics.error(Location{scene.file, 1, 1}, "the scene defines no objects");
    throw SceneError(diagnostics);
  }

  // Each object on its own.
  std::vector<ObjectPart> parts(scene.objects.size());
  for (std::size_t k = 0; k < scene.objects.size(); ++k) {
    const ObjectSpec& o = scene.objects[k];
    ObjectPart& part = parts[k];
    part.spec = &o;
    if (o.kind.value == "tissue") {
      if (o.surface) make_meshless_tissue(scene, part, budget, diagnostics);
      else if (o.image) make_image_tissue(scene, part, budget, diagnostics);
      else if (!o.between.empty()) continue;  // built from its organs below
      else make_mesh_tissue(scene, part, budget, diagnostics);
      place_fibres(o, part.part, nullptr, diagnostics);
    } else if (o.kind.value == "shell") {
      if (!read_transformed_surface(o, part.surface, budget, diagnostics)) continue;
      const MaterialSpec* m = scene.material(o.material->value);
      part.shell = ShellProperties{o.thickness->value, m->young.value, m->poisson.value, m->density.value};
      part.discretisation = "shell, " + std::to_string(part.surface.triangle_count()) + " triangles, " +
                            std::to_string(part.surface.vertex_count()) + " frames, thickness " +
                            metres(o.thickness->value);
    } else {
      if (!read_transformed_surface(o, part.surface, budget, diagnostics)) continue;
      part.density = o.density ? o.density->value
                               : (o.material ? scene.material(o.material->value)->density.value : 1000.0);
      part.discretisation = "rigid, " + std::to_string(part.surface.triangle_count()) + " triangles";
    }
  }
  if (!diagnostics.empty()) throw SceneError(diagnostics);
  for (ObjectPart& part : parts)
    if (!part.spec->between.empty()) make_between_tissue(scene, parts, part, budget, diagnostics);
  if (!diagnostics.empty()) throw SceneError(diagnostics);

  const bool single = parts.size() == 1 && scene.objects[0].kind.value == "tissue" && scene.couplings.empty();
  if (single) {
    // One tissue: its model as built (keeps lock_rotations' flag and frame order).
    built.model = std::move(parts[0].part);
    parts[0].part.frame_rest_positions = built.model.frame_rest_positions;
    parts[0].frames.resize(static_cast<std::size_t>(built.model.frame_count()));
    for (int i = 0; i < built.model.frame_count(); ++i) parts[0].frames[static_cast<std::size_t>(i)] = i;
  } else {
    ModelBuilder builder;
    for (ObjectPart& part : parts) {
      const ObjectSpec& o = *part.spec;
      try {
        if (o.kind.value == "tissue") {
          builder.add_tissue(o.name, part.part, part.surface);
        } else if (o.kind.value == "shell") {
          builder.add_shell(o.name, part.surface, part.shell);
        } else {
          const int index = builder.add_rigid(o.name, part.surface, part.density);
          if (o.fixed && o.fixed->value) builder.fix(index, [](double, double, double) { return true; });
        }
      } catch (const std::exception& e) {
        diagnostics.error(o.where, "cannot build '" + o.name + "': " + e.what());
      }
    }
    if (!diagnostics.empty()) throw SceneError(diagnostics);
    // A tissue between two organs is bound to each: its frames within frame_spacing of an organ's
    // rest surface are shared with it (attached to it when rigid).
    for (const ObjectPart& part : parts) {
      const ObjectSpec& o = *part.spec;
      if (o.between.empty()) continue;
      const double within = o.meshless->frame_spacing.value;
      for (const Located<std::string>& organ : o.between) {
        const int it = builder.find(o.name), io = builder.find(organ.value);
        const bool rigid = scene.object(organ.value)->kind.value == "rigid";
        try {
          const int n = rigid ? builder.attach(it, io, within) : builder.share(it, io, within);
          built.couplings.push_back(CouplingReport{rigid ? "attach" : "share", o.name, organ.value, n, within, organ.where});
          if (n == 0)
            diagnostics.error(organ.where, "no frame of '" + o.name + "' lies within frame_spacing " + metres(within) +
                                               " of '" + organ.value + "': use a smaller frame_spacing");
        } catch (const std::invalid_argument& e) {
          diagnostics.error(organ.where, e.what());
        }
      }
    }
    if (!diagnostics.empty()) throw SceneError(diagnostics);
    for (const CouplingSpec& c : scene.couplings) {
      const double within = c.within ? c.within->value : 2e-3;
      const Location where = c.within ? c.within->where : c.where;
      const bool is_share = !c.share.empty();
      const Located<std::string>& a = is_share ? c.share[0] : *c.attach;
      const Located<std::string>& b = is_share ? c.share[1] : *c.to;
      const int ia = builder.find(a.value), ib = builder.find(b.value);
      if (ia < 0 || ib < 0) {
        const Located<std::string>& bad = ia < 0 ? a : b;
        diagnostics.error(bad.where, "unknown object '" + bad.value + "' in coupling");
        continue;
      }
      if (ia == ib) {
        diagnostics.error(b.where, "object '" + a.value + "' is coupled with itself");
        continue;
      }
      try {
        const int n = is_share ? builder.share(ia, ib, within) : builder.attach(ia, ib, within);
        built.couplings.push_back(CouplingReport{is_share ? "share" : "attach", a.value, b.value, n, within, c.where});
        if (n == 0)
          diagnostics.error(where, std::string(is_share ? "share" : "attach") + ": no frame of '" + a.value +
                                       "' lies within " + metres(within) + " of the surface of '" + b.value +
                                       "' (rest positions); increase 'within' or move the objects together");
      } catch (const std::invalid_argument& e) {
        diagnostics.error(c.where, e.what());
      }
    }
    if (!diagnostics.empty()) throw SceneError(diagnostics);
    try {
      built.model = builder.build();
    } catch (const std::exception& e) {
      diagnostics.error(Location{scene.file, 1, 1}, std::string("cannot assemble the scene: ") + e.what());
      throw SceneError(diagnostics);
    }
    for (std::size_t k = 0; k < parts.size(); ++k) parts[k].frames = built.model.objects[k].frames;
  }
  for (const ObjectPart& part : parts) built.objects.push_back(output_object(part, built.model));
  finish_scene(scene, parts, built, diagnostics);
  return built;
}

namespace {

// Constraints, loads and solver settings.
void finish_scene(const SceneSpec& scene, std::vector<ObjectPart>& parts, BuiltScene& built, Diagnostics& diagnostics) {
  Model& model = built.model;
  auto part_of = [&](const std::string& name) -> const ObjectPart& {
    for (const ObjectPart& p : parts)
      if (p.spec->name == name) return p;
    return parts.front();  // names were checked by the parser
  };
  // Constraints.
  bool fixed_any = false;
  for (const ObjectPart& p : parts) fixed_any = fixed_any || (p.spec->fixed && p.spec->fixed->value);
  for (const ConstraintSpec& c : scene.constraints) {
    const std::vector<int> frames = select_frames(model, part_of(c.object.value).frames, c.region, c.object.value, diagnostics);
    for (int i : frames) {
      for (int k = 0; k < (c.translations_only ? 3 : 6); ++k)
        model.fixed_dofs[static_cast<std::size_t>(kFrameDofs * i + k)] = 1;
    }
    fixed_any = fixed_any || !frames.empty();
  }

  // Loads.
  Vec3 gravity{0, 0, 0};
  for (const LoadSpec& l : scene.loads) {
    if (l.kind == LoadSpec::Kind::gravity) {
      gravity += to_vec3(l.vector.value);
      continue;
    }
    const std::string& name = l.object->value;
    const ObjectPart& part = part_of(name);
    if (l.kind == LoadSpec::Kind::surface_force) {
      if (!part.mesh_based) {
        // One material-point force per selected triangle, traction x area at its centroid,
        // carried by the frames through the shape functions there (meshless, consistent with
        // eq. 3), by the nearest vertex's frame (shell) or by the body's frame (rigid).
        const SurfaceMesh& surf = part.surface;
        const double tol = region_tolerance(model);
        std::vector<double> centroids, forces;
        for (int t = 0; t < surf.triangle_count(); ++t) {
          Vec3 p[3];
          for (int j = 0; j < 3; ++j) p[j] = load3(&surf.vertices[3 * static_cast<std::size_t>(surf.triangles[3 * static_cast<std::size_t>(t) + static_cast<std::size_t>(j)])]);
          const Vec3 c = (1.0 / 3.0) * (p[0] + p[1] + p[2]);
          if (!l.region->contains({c.x, c.y, c.z}, tol)) continue;
          const double area = 0.5 * norm(cross(p[1] - p[0], p[2] - p[0]));
          if (part.meshless) {
            centroids.insert(centroids.end(), {c.x, c.y, c.z});
            for (int k = 0; k < 3; ++k) forces.push_back(l.vector.value[static_cast<std::size_t>(k)] * area);
          } else {
            // Shell and rigid: equal shares at the triangle's vertices (shell) or the body frame.
            const Vec3 f = area * to_vec3(l.vector.value);
            if (part.spec->kind.value == "rigid") {
              built.loads.point_forces.push_back({part.frames.front(), f});
            } else {
              for (int j = 0; j < 3; ++j)
                built.loads.point_forces.push_back(
                    {part.frames[static_cast<std::size_t>(surf.triangles[3 * static_cast<std::size_t>(t) + static_cast<std::size_t>(j)])],
                     (1.0 / 3.0) * f});
            }
            centroids.insert(centroids.end(), {c.x, c.y, c.z});
          }
        }
        if (centroids.empty()) {
          diagnostics.error(l.region->where, "region selects no surface triangles of object '" + name +
                                                 "' (a triangle is selected when its centre is inside)");
          continue;
        }
        if (!part.meshless) continue;
        const NeighbourTable table = object_table(part, model, centroids);
        for (std::size_t q = 0; q < centroids.size() / 3; ++q) {
          MaterialPointForce f;
          for (int pr = table.offsets[q]; pr < table.offsets[q + 1]; ++pr) {
            f.frames.push_back(table.frames[static_cast<std::size_t>(pr)]);
            f.weights.push_back(table.weights[static_cast<std::size_t>(pr)]);
            for (int k = 0; k < 3; ++k)
              f.rest_offsets.push_back(table.rest_offsets[3 * static_cast<std::size_t>(pr) + static_cast<std::size_t>(k)]);
          }
          f.force = Vec3{forces[3 * q], forces[3 * q + 1], forces[3 * q + 2]};
          built.loads.material_point_forces.push_back(std::move(f));
        }
        continue;
      }
      const VolumeMesh& mesh = part.mesh;
      const BoundarySurface& boundary = part.boundary;
      std::vector<double> nodal(3 * static_cast<std::size_t>(mesh.vertex_count()), 0.0);
      const double tol = region_tolerance(model);
      int selected = 0;
      for (int f = 0; f < boundary.face_count(); ++f) {
        Vec3d centre;
        const double area = face_area(mesh, boundary, f, centre);
        if (!l.region->contains(centre, tol)) continue;
        ++selected;
        // Equal shares per face vertex: exact for linear triangles and for parallelogram quads.
        for (int j = 0; j < boundary.nodes_per_face; ++j) {
          const int v = boundary.vertices[static_cast<std::size_t>(boundary.faces[static_cast<std::size_t>(f * boundary.nodes_per_face + j)])];
          for (int c = 0; c < 3; ++c)
            nodal[3 * static_cast<std::size_t>(v) + static_cast<std::size_t>(c)] +=
                l.vector.value[static_cast<std::size_t>(c)] * area / boundary.nodes_per_face;
        }
      }
      if (selected == 0) {
        diagnostics.error(l.region->where, "region selects no boundary faces of object '" + name +
                                               "' (a face is selected when its centre is inside)");
        continue;
      }
      for (int i = 0; i < mesh.vertex_count(); ++i) {
        const double* f = &nodal[3 * static_cast<std::size_t>(i)];
        if (f[0] != 0 || f[1] != 0 || f[2] != 0)
          built.loads.point_forces.push_back({part.frames[static_cast<std::size_t>(i)], Vec3{f[0], f[1], f[2]}});
      }
      continue;
    }
    const std::vector<int> frames = select_frames(model, part.frames, *l.region, name, diagnostics);
    if (frames.empty()) continue;
    if (l.kind == LoadSpec::Kind::point_force) {
      const Vec3 share = (1.0 / static_cast<double>(frames.size())) * to_vec3(l.vector.value);
      for (int i : frames) built.loads.point_forces.push_back({i, share});
    } else {
      PrescribedMotion motion;
      motion.frames = frames;
      motion.velocity = to_vec3(l.vector.value);
      if (l.angular_velocity) {
        motion.rotates = true;
        motion.angular_velocity = to_vec3(l.angular_velocity->value);
        if (l.pivot) {
          motion.pivot = to_vec3(l.pivot->value);
        } else if (part.spec->kind.value == "rigid") {
          motion.pivot = load3(&model.frame_rest_positions[3 * static_cast<std::size_t>(part.frames.front())]);
        } else {
          for (int i : frames) motion.pivot += load3(&model.frame_rest_positions[3 * static_cast<std::size_t>(i)]);
          motion.pivot = (1.0 / static_cast<double>(frames.size())) * motion.pivot;
        }
      }
      motion.start = l.start;
      if (l.end) motion.end = *l.end;
      built.motions.push_back(motion);
      fixed_any = true;
    }
  }
  built.loads.gravity = gravity;

  const SolverSpec& s = scene.solver;
  if (s.integrator.value == "static" && !fixed_any && diagnostics.empty()) {
    const std::string& name = parts.front().spec->name;
    diagnostics.error(s.integrator.where, "static solve: object '" + name +
                                              "' has no fixed frames, so its equilibrium is not defined; add a "
                                              "constraint (constraints: [{fix: " + name + ", region: ...}])");
  }
  if (!diagnostics.empty()) throw SceneError(diagnostics);

  SimulationSettings& settings = built.settings;
  settings.integrator = parse_integrator(s.integrator.value);
  settings.dt = s.dt.value;
  settings.rayleigh_mass = s.rayleigh_mass;
  settings.rayleigh_stiffness = s.rayleigh_stiffness;
  settings.load_steps = s.load_steps;
  settings.max_load_halvings = s.max_load_halvings;
  settings.threads = s.threads;
  settings.adaptive.enabled = s.adaptive;
  settings.adaptive.tolerance = s.adaptive_tolerance;
  settings.adaptive.min_dt = s.adaptive_min_dt;
  settings.adaptive.max_dt = s.adaptive_max_dt;
  settings.newton.tolerance = s.newton_tolerance;
  settings.newton.max_iterations = s.newton_max_iterations;
  settings.newton.max_backtracks = s.newton_max_backtracks;
  settings.newton.fixed_iterations = s.newton_fixed_iterations;
  settings.newton.linear.method = parse_linear_method(s.linear_method.value);
  settings.newton.linear.preconditioner = parse_preconditioner(s.linear_preconditioner.value);
  settings.newton.linear.tolerance = s.linear_tolerance;
  settings.newton.linear.max_iterations = s.linear_max_iterations;
  settings.newton.linear.fixed_iterations = s.linear_fixed_iterations;
  built.steps = scene.run.step_count;
  built.stats = discretisation_stats(model);
}

}  // namespace

}  // namespace fascia::dsl
