// SceneSpec: a validated scene in SI units, every value with the file:line:col it came from.
// Produced by dsl::parse_scene, consumed by dsl::build_scene and the command line.
#pragma once

#include "dsl/diagnostics.hpp"
#include "dsl/value.hpp"

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace fascia::dsl {

template <class T>
struct Located {
  T value{};
  Location where;
};

using Vec3d = std::array<double, 3>;

// The fibres of an hgo material.
struct FibresSpec {
  Location where;
  Located<double> k1;          // Pa
  Located<double> k2;          // dimensionless
  Located<double> dispersion;  // kappa in [0, 1/3]
  std::optional<Located<Vec3d>> direction;  // nonzero, normalised when built; two families: their mean
  Located<int> families;                    // 1 or 2
  std::optional<Located<double>> angle;     // two families: gamma in [0, pi/2], rad
  std::optional<Located<Vec3d>> plane;      // two families: not parallel to the direction
};

struct MaterialSpec {
  std::string name;
  Location where;
  Located<std::string> law;  // "stvk" | "neo_hookean" | "hgo"
  Located<double> young;     // Pa
  Located<double> poisson;
  Located<double> density;  // kg/m^3
  std::optional<FibresSpec> fibres;  // hgo
  std::optional<Located<std::string>> formulation;  // hgo: "coupled" (when absent) | "uncoupled"
};

// A selection of frames (constraints, loads) or boundary faces (surface forces), tested on rest
// positions in world axes after the object's transform.
struct RegionSpec {
  enum class Kind { all, box, sphere, half_space, ids };
  Kind kind = Kind::all;
  Location where;
  Vec3d lo{}, hi{};        // box, m
  Vec3d center{};          // sphere, m
  double radius = 0;       // sphere, m
  Vec3d point{}, normal{}; // half-space: (p - point) . normal <= 0
  std::vector<int> ids;    // explicit frame indices

  // Whether a point lies in the region; `tolerance` (m) widens it to catch points on its border.
  bool contains(const Vec3d& p, double tolerance) const;
  // Signed distance from p to the region's boundary, m, negative inside: exact for box, sphere
  // and half_space; -infinity for all. Not defined for ids (they select frames, not points).
  double signed_distance(const Vec3d& p) const;
};

struct BoxSpec {
  Located<Vec3d> min, max;          // m
  Located<std::array<int, 3>> cells;
  Located<std::string> elements;    // "hex" | "tet"
};

struct MeshlessSpec {
  Located<double> frame_spacing, sample_spacing;  // m
  Located<std::string> shape;       // "mls"
  Located<int> neighbours;          // k: frame supports from the k-th nearest frame
  Located<long long> seed;          // Poisson-disk seed
  Located<std::string> thin_parts;  // "repair" | "stop"
};

struct TransformSpec {
  double scale = 1;
  Vec3d rotate{0, 0, 0};     // rad, applied x then y then z
  Vec3d translate{0, 0, 0};  // m
  // p -> translate + Rz Ry Rx (scale p)
  Vec3d apply(const Vec3d& p) const;
};

// Where the fibres of a tissue of an hgo material run (exactly one of the three).
struct ObjectFibresSpec {
  struct Region {
    RegionSpec region;
    Located<Vec3d> direction;
  };
  Location where;
  std::optional<Located<Vec3d>> direction;    // one direction for the object
  std::optional<Located<std::string>> from;  // an organ of between: the gradient of the distance to it
  std::vector<Region> regions;                 // first match wins; the material's direction elsewhere
};

struct ObjectSpec {
  std::string name;
  Location where;
  Located<std::string> kind;  // "tissue" | "shell" | "rigid"
  std::optional<Located<std::string>> material;
  std::optional<Located<std::string>> mesh;     // resolved path of a volume mesh
  std::optional<BoxSpec> box;
  std::optional<Located<std::string>> surface;  // resolved path of a surface mesh
  std::optional<Located<std::string>> image;    // resolved path of a label image
  std::optional<Located<std::vector<int>>> label;  // labels of the image forming the object
  std::optional<Located<double>> smoothing;        // with image: standard deviation, m
  std::vector<Located<std::string>> between;  // two organs bounding a connective tissue
  std::optional<Located<double>> within;        // with between, m
  std::optional<RegionSpec> region;             // with between: the tissue restricted to it
  Located<int> quadrature;
  std::optional<MeshlessSpec> meshless;
  TransformSpec transform;
  bool lock_rotations = false;
  std::optional<Located<double>> thickness, density;
  std::optional<Located<bool>> fixed;
  std::optional<ObjectFibresSpec> fibres;
};

struct ConstraintSpec {
  Location where;
  Located<std::string> object;
  RegionSpec region;
  bool translations_only = false;
};

struct LoadSpec {
  enum class Kind { gravity, point_force, surface_force, motion };
  Kind kind = Kind::gravity;
  Location where;
  Located<Vec3d> vector;               // gravity (m/s^2), force (N), traction (Pa), velocity (m/s)
  std::optional<Located<std::string>> object;
  std::optional<RegionSpec> region;
  std::optional<Located<Vec3d>> angular_velocity;  // motion, rad/s
  std::optional<Located<Vec3d>> pivot;             // motion, m
  double start = 0;                    // motion, s
  std::optional<double> end;           // motion, s
};

struct CouplingSpec {
  Location where;
  std::vector<Located<std::string>> share;
  std::optional<Located<std::string>> attach, to;
  std::optional<Located<double>> within;
};

struct SolverSpec {
  Located<std::string> integrator;  // "static" | "backward_euler" | "variational"
  Located<double> dt;               // s
  double rayleigh_mass = 0, rayleigh_stiffness = 0;
  int load_steps = 1, max_load_halvings = 10, threads = 0;
  bool adaptive = false;                     // solver.adaptive given
  double adaptive_tolerance = 0;             // m
  double adaptive_min_dt = 1e-6, adaptive_max_dt = 0;  // s; max 0: none
  double newton_tolerance = 1e-6;
  int newton_max_iterations = 50, newton_max_backtracks = 30, newton_fixed_iterations = 0;
  Located<std::string> linear_method;
  Located<std::string> linear_preconditioner;
  double linear_tolerance = 1e-8;
  int linear_max_iterations = 2000;
  bool linear_fixed_iterations = false;
};

// The most steps a run takes (step numbers are 32-bit integers in the output).
constexpr int kMaxSteps = 2147483647;

struct RunSpec {
  std::optional<Located<double>> duration;  // s
  std::optional<Located<int>> steps;
  Location where;
  int step_count = 1;  // resolved
};

struct OutputSpec {
  std::string file;  // resolved: output.file or <scene stem>.h5
  int every = 1;
  bool samples = true;
  bool xdmf = true;
  int checkpoint_every = 0;           // steps, 0 = off
  double checkpoint_interval = 600;   // wall-clock s, 0 = off
};

struct SceneSpec {
  std::string file;  // the scene's path as given
  std::vector<MaterialSpec> materials;
  std::vector<ObjectSpec> objects;
  std::vector<ConstraintSpec> constraints;
  std::vector<LoadSpec> loads;
  std::vector<CouplingSpec> couplings;
  SolverSpec solver;
  RunSpec run;
  OutputSpec output;
  Value resolved;               // the validated tree (SI, defaults)
  std::string resolved_yaml;    // the same as YAML text (stored under /parameters)

  const MaterialSpec* material(const std::string& name) const;
  const ObjectSpec* object(const std::string& name) const;
};

// Reads, merges (include/extends), overrides (--set path=value, in order), validates and
// cross-checks a scene. Throws SceneError with every problem found.
SceneSpec parse_scene(const std::string& path, const std::vector<std::string>& overrides = {});

// The same from YAML text (tests); `file` names it in messages, relative paths resolve from it.
SceneSpec parse_scene_text(const std::string& text, const std::string& file,
                           const std::vector<std::string>& overrides = {});

}  // namespace fascia::dsl
