#include "dsl/build_scene.hpp"

#include "discretise/mesh_based.hpp"
#include "discretise/meshless.hpp"
#include "discretise/surface_mesh.hpp"
#include "shape/meshless_shape.hpp"
#include "io/boundary_surface.hpp"
#include "io/volume_mesh_io.hpp"

#include <algorithm>
#include <cmath>
#include <ios>
#include <limits>

namespace fascia::dsl {

namespace {

Vec3 to_vec3(const Vec3d& v) { return Vec3{v[0], v[1], v[2]}; }

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

// Frames of the region; reports ids out of range and empty selections.
std::vector<int> select_frames(const Model& model, const RegionSpec& region, const std::string& object,
                               Diagnostics& diagnostics) {
  std::vector<int> out;
  if (region.kind == RegionSpec::Kind::ids) {
    for (int id : region.ids) {
      if (id < 0 || id >= model.frame_count()) {
        diagnostics.error(region.where, "frame id " + std::to_string(id) + " is out of range: object '" + object +
                                            "' has " + std::to_string(model.frame_count()) + " frames (0.." +
                                            std::to_string(model.frame_count() - 1) + ")");
        return {};
      }
      out.push_back(id);
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }
  const double tol = region_tolerance(model);
  for (int i = 0; i < model.frame_count(); ++i)
    if (region.contains(frame_position(model, i), tol)) out.push_back(i);
  if (out.empty())
    diagnostics.error(region.where, "region selects no frames of object '" + object +
                                        "' (frames are tested at their rest positions, world axes, metres)");
  return out;
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
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    double* x = &mesh.vertices[3 * static_cast<std::size_t>(v)];
    const Vec3d p = o.transform.apply({x[0], x[1], x[2]});
    x[0] = p[0];
    x[1] = p[1];
    x[2] = p[2];
  }
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

// The geometry a surface force needs: the volume mesh boundary (mesh-based) or the input surface
// with the shape functions that carry it (meshless).
struct ForceSurface {
  const VolumeMesh* mesh = nullptr;
  const BoundarySurface* boundary = nullptr;
  const SurfaceMesh* surface = nullptr;
  const MeshlessShapeOptions* shape = nullptr;
};

void finish_scene(const SceneSpec& scene, const ObjectSpec& tissue_spec, const ForceSurface& geometry,
                  BuiltScene& built, Diagnostics& diagnostics);
BuiltScene build_meshless(const SceneSpec& scene, const ObjectSpec& o, const Material& material);

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

BuiltScene build_scene(const SceneSpec& scene) {
  Diagnostics diagnostics;
  BuiltScene built;

  // Objects: one mesh-based tissue for now; other kinds are reported, not silently ignored.
  const ObjectSpec* tissue = nullptr;
  for (const ObjectSpec& o : scene.objects) {
    if (o.kind.value == "shell" || o.kind.value == "rigid") {
      diagnostics.error(o.kind.where, o.kind.value + " objects are not supported yet ('" + o.name +
                                          "'; coupling with organs and bones comes in a later version)");
      continue;
    }
    if (tissue) {
      diagnostics.error(o.where, "several tissue objects are not supported yet ('" + tissue->name + "' and '" +
                                     o.name + "'); coupling comes in a later version");
      continue;
    }
    tissue = &o;
  }
  for (const CouplingSpec& c : scene.couplings)
    diagnostics.error(c.where, "couplings are not supported yet");
  if (scene.objects.empty()) diagnostics.error(Location{scene.file, 0, 0}, "the scene defines no objects");
  if (!diagnostics.empty()) throw SceneError(diagnostics);
  if (!tissue) throw SceneError(diagnostics);

  const MaterialSpec* m = scene.material(tissue->material->value);
  const MaterialLaw law = m->law.value == "neo_hookean" ? MaterialLaw::neo_hookean : MaterialLaw::stvk;
  const Material material = make_material(law, m->young.value, m->poisson.value, m->density.value);
  if (tissue->surface) return build_meshless(scene, *tissue, material);

  // Discretisation.
  VolumeMesh mesh = object_mesh(*tissue, diagnostics);
  if (!diagnostics.empty()) throw SceneError(diagnostics);
  const int q = tissue->quadrature.value;
  const bool tet = mesh.type == CellType::tetrahedron;
  if (q != 0 && (tet ? (q != 1 && q != 4) : (q != 1 && q != 8 && q != 27))) {
    diagnostics.error(tissue->quadrature.where, std::string("quadrature ") + std::to_string(q) + " is not available for " +
                                                    (tet ? "tetrahedra (use 1 or 4)" : "hexahedra (use 1, 8 or 27)"));
    throw SceneError(diagnostics);
  }
  MeshDiscretisation options;
  options.quadrature = tet ? q : (q == 1 ? 1 : q == 27 ? 3 : q == 8 ? 2 : 0);
  try {
    built.model = build_mesh_model(mesh, material, options);
  } catch (const std::invalid_argument& e) {
    const Location where = tissue->mesh ? tissue->mesh->where : tissue->where;
    diagnostics.error(where, std::string("cannot discretise '") + tissue->name + "': " + e.what(),
                      tissue->mesh ? ExitCode::bad_data : ExitCode::bad_scene);
    throw SceneError(diagnostics);
  }
  if (tissue->lock_rotations) lock_rotations(built.model);

  const BoundarySurface boundary = boundary_surface(mesh);
  BuiltObject object;
  object.name = tissue->name;
  object.surface.name = tissue->name;
  object.surface.nodes_per_face = boundary.nodes_per_face;
  object.surface.faces = boundary.faces;
  object.surface.vertex_frames = boundary.vertices;  // mesh-based: frame i = vertex i
  object.discretisation = std::string("mesh-based, ") + std::to_string(mesh.cell_count()) +
                          (tet ? " tetrahedra" : " hexahedra");
  built.objects.push_back(object);

  finish_scene(scene, *tissue, ForceSurface{&mesh, &boundary, nullptr, nullptr}, built, diagnostics);
  return built;
}

namespace {

// Constraints, loads and solver settings, common to mesh-based and meshless tissues.
void finish_scene(const SceneSpec& scene, const ObjectSpec& tissue_spec, const ForceSurface& geometry,
                  BuiltScene& built, Diagnostics& diagnostics) {
  const ObjectSpec* tissue = &tissue_spec;
  Model& model = built.model;
  // Constraints.
  bool fixed_any = false;
  for (const ConstraintSpec& c : scene.constraints) {
    const std::vector<int> frames = select_frames(model, c.region, c.object.value, diagnostics);
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
    if (l.kind == LoadSpec::Kind::surface_force) {
      if (geometry.surface) {
        // Meshless: one material-point force per selected triangle, traction x area at its
        // centroid, carried by the frames through the shape functions there (consistent with eq. 3).
        const SurfaceMesh& surf = *geometry.surface;
        const double tol = region_tolerance(model);
        std::vector<double> centroids, forces;
        for (int t = 0; t < surf.triangle_count(); ++t) {
          Vec3 p[3];
          for (int j = 0; j < 3; ++j) p[j] = load3(&surf.vertices[3 * static_cast<std::size_t>(surf.triangles[3 * static_cast<std::size_t>(t) + static_cast<std::size_t>(j)])]);
          const Vec3 c = (1.0 / 3.0) * (p[0] + p[1] + p[2]);
          if (!l.region->contains({c.x, c.y, c.z}, tol)) continue;
          const double area = 0.5 * norm(cross(p[1] - p[0], p[2] - p[0]));
          centroids.insert(centroids.end(), {c.x, c.y, c.z});
          for (int k = 0; k < 3; ++k) forces.push_back(l.vector.value[static_cast<std::size_t>(k)] * area);
        }
        if (centroids.empty()) {
          diagnostics.error(l.region->where, "region selects no surface triangles of object '" + name +
                                                 "' (a triangle is selected when its centre is inside)");
          continue;
        }
        const MeshlessTable table = build_meshless_table(model.frame_rest_positions, centroids, *geometry.shape);
        for (std::size_t q = 0; q < centroids.size() / 3; ++q) {
          MaterialPointForce f;
          for (int pr = table.neighbours.offsets[q]; pr < table.neighbours.offsets[q + 1]; ++pr) {
            f.frames.push_back(table.neighbours.frames[static_cast<std::size_t>(pr)]);
            f.weights.push_back(table.neighbours.weights[static_cast<std::size_t>(pr)]);
            for (int k = 0; k < 3; ++k)
              f.rest_offsets.push_back(table.neighbours.rest_offsets[3 * static_cast<std::size_t>(pr) + static_cast<std::size_t>(k)]);
          }
          f.force = Vec3{forces[3 * q], forces[3 * q + 1], forces[3 * q + 2]};
          built.loads.material_point_forces.push_back(std::move(f));
        }
        continue;
      }
      const VolumeMesh& mesh = *geometry.mesh;
      const BoundarySurface& boundary = *geometry.boundary;
      std::vector<double> nodal(3 * static_cast<std::size_t>(model.frame_count()), 0.0);
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
      for (int i = 0; i < model.frame_count(); ++i) {
        const double* f = &nodal[3 * static_cast<std::size_t>(i)];
        if (f[0] != 0 || f[1] != 0 || f[2] != 0) built.loads.point_forces.push_back({i, Vec3{f[0], f[1], f[2]}});
      }
      continue;
    }
    const std::vector<int> frames = select_frames(model, *l.region, name, diagnostics);
    if (frames.empty()) continue;
    if (l.kind == LoadSpec::Kind::point_force) {
      const Vec3 share = (1.0 / static_cast<double>(frames.size())) * to_vec3(l.vector.value);
      for (int i : frames) built.loads.point_forces.push_back({i, share});
    } else {
      PrescribedMotion motion;
      motion.frames = frames;
      motion.velocity = to_vec3(l.vector.value);
      motion.start = l.start;
      if (l.end) motion.end = *l.end;
      built.motions.push_back(motion);
      fixed_any = true;
    }
  }
  built.loads.gravity = gravity;

  const SolverSpec& s = scene.solver;
  if (s.integrator.value == "static" && !fixed_any && diagnostics.empty()) {
    diagnostics.error(s.integrator.where, "static solve: object '" + tissue->name +
                                              "' has no fixed frames, so its equilibrium is not defined; add a "
                                              "constraint (constraints: [{fix: " + tissue->name + ", region: ...}])");
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
  settings.newton.tolerance = s.newton_tolerance;
  settings.newton.max_iterations = s.newton_max_iterations;
  settings.newton.max_backtracks = s.newton_max_backtracks;
  settings.newton.fixed_iterations = s.newton_fixed_iterations;
  settings.newton.linear.method = parse_linear_method(s.linear_method.value);
  settings.newton.linear.tolerance = s.linear_tolerance;
  settings.newton.linear.max_iterations = s.linear_max_iterations;
  settings.newton.linear.fixed_iterations = s.linear_fixed_iterations;
  built.steps = scene.run.step_count;
  built.stats = discretisation_stats(model);
}

BuiltScene build_meshless(const SceneSpec& scene, const ObjectSpec& o, const Material& material) {
  Diagnostics diagnostics;
  BuiltScene built;
  SurfaceMesh surface;
  try {
    surface = read_surface_mesh(o.surface->value);
  } catch (const std::exception& e) {
    diagnostics.error(o.surface->where, std::string("surface: ") + e.what(), ExitCode::bad_data);
    throw SceneError(diagnostics);
  }
  for (int v = 0; v < surface.vertex_count(); ++v) {
    double* x = &surface.vertices[3 * static_cast<std::size_t>(v)];
    const Vec3d p = o.transform.apply({x[0], x[1], x[2]});
    x[0] = p[0];
    x[1] = p[1];
    x[2] = p[2];
  }
  const MeshlessSpec& ml = *o.meshless;
  MeshlessOptions options;
  options.frame_spacing = ml.frame_spacing.value;
  options.sample_spacing = ml.sample_spacing.value;
  options.shape.kind = ml.shape.value == "rbf" ? MeshlessShapeKind::rbf : MeshlessShapeKind::mls;
  options.shape.neighbours = ml.neighbours.value;
  options.seed = static_cast<std::uint64_t>(ml.seed.value);
  options.thin_parts = ml.thin_parts.value == "stop" ? ThinParts::stop : ThinParts::repair;
  if (!(options.sample_spacing < options.frame_spacing)) {
    diagnostics.error(ml.sample_spacing.where, "sample_spacing must be smaller than frame_spacing");
    throw SceneError(diagnostics);
  }
  MeshlessBuild result;
  try {
    result = build_meshless_model(surface, material, options);
  } catch (const std::exception& e) {
    diagnostics.error(ml.frame_spacing.where, "cannot discretise '" + o.name + "': " + e.what());
    throw SceneError(diagnostics);
  }
  built.model = std::move(result.model);
  if (o.lock_rotations) lock_rotations(built.model);

  // The input surface, carried by the frames like samples: weights at its vertices.
  BuiltObject object;
  object.name = o.name;
  object.surface.name = o.name;
  object.surface.nodes_per_face = 3;
  object.surface.faces = surface.triangles;
  object.surface.vertex_frames.assign(static_cast<std::size_t>(surface.vertex_count()), -1);
  object.skinned = true;
  object.skin = build_meshless_table(built.model.frame_rest_positions, surface.vertices, options.shape).neighbours;
  object.discretisation = "meshless (" + ml.shape.value + "), " + std::to_string(surface.triangle_count()) +
                          " surface triangles, " + std::to_string(result.statistics.added_frames) +
                          " frames added in thin parts";
  object.meshless = result.statistics;
  built.objects.push_back(object);

  finish_scene(scene, o, ForceSurface{nullptr, nullptr, &surface, &options.shape}, built, diagnostics);
  return built;
}

}  // namespace

}  // namespace fascia::dsl
