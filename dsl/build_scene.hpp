// SceneSpec -> engine objects: geometry, discretisation, constraints, loads, solver settings.
#pragma once

#include "discretise/meshless.hpp"
#include "dsl/resource_estimate.hpp"
#include "dsl/scene_spec.hpp"
#include "integrate/simulation.hpp"
#include "io/trajectory.hpp"

#include <optional>
#include <string>
#include <vector>

namespace fascia::dsl {

// Discretisation figures printed by `fascia check` and `fascia run`.
struct DiscretisationStats {
  int frames = 0, samples = 0, dofs = 0, fixed_frames = 0;
  int neighbours_min = 0, neighbours_max = 0;
  double neighbours_mean = 0;
  double volume = 0;  // m^3
  double mass = 0;    // kg
};

// What one coupling of the scene did (`fascia check`): `frames` frames of `object` were merged into
// frames of `other` (share) or made to follow rigid body `other` (attach).
struct CouplingReport {
  std::string kind;    // "share" | "attach"
  std::string object;  // a
  std::string other;   // b
  int frames = 0;
  double within = 0;   // m
  Location where;      // the coupling in the scene
};

struct BuiltObject {
  std::string name;
  // Boundary surface. Mesh-based objects: its vertices are frames (vertex_frames). Meshless
  // objects: the input surface, its vertices placed through the frames like samples (eq. 3) with
  // the weights in `skin` (vertex_frames are -1).
  SurfaceLayout surface;
  bool skinned = false;
  NeighbourTable skin;  // [V] rows: surface vertex -> frames, weights, rest offsets
  std::string discretisation;  // one-line description for `fascia check`
  std::optional<MeshlessStatistics> meshless;  // meshless objects: what the build reports
};

struct BuiltScene {
  Model model;
  ExternalLoads loads;
  SimulationSettings settings;
  std::vector<PrescribedMotion> motions;
  std::vector<BuiltObject> objects;
  std::vector<CouplingReport> couplings;  // in the scene's order
  int steps = 1;
  DiscretisationStats stats;
};

// Builds the model: every object (mesh-based or meshless tissue, shell, rigid body), assembled by
// ModelBuilder with the couplings (share, attach) when there is more than one object or any
// coupling; a single tissue is used as discretised. Throws SceneError (all problems at once) for
// unreadable meshes (ExitCode::missing_input / bad_data), couplings that catch no frame or pair
// the wrong kinds, empty region selections, frame ids out of range, and a static solve without
// fixed frames. Before each object is read or discretised, its memory is estimated
// (dsl/resource_estimate.hpp); a scene whose objects together exceed `limits.max_memory` is
// refused with ExitCode::too_large at the value that asks for it.
BuiltScene build_scene(const SceneSpec& scene, const ResourceLimits& limits = {});

DiscretisationStats discretisation_stats(const Model& model);

}  // namespace fascia::dsl
