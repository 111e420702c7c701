#include "dsl/registry.hpp"

#include <sstream>

namespace fascia::dsl {

const ParamSpec* ParamSpec::child(const std::string& key) const {
  for (const ParamSpec& c : children)
    if (c.name == key) return &c;
  return nullptr;
}

std::vector<std::string> ParamSpec::child_names() const {
  std::vector<std::string> names;
  for (const ParamSpec& c : children) names.push_back(c.name);
  return names;
}

namespace {

std::string number_text(double v) {
  std::ostringstream os;
  os.precision(12);
  os << v;
  return os.str();
}

std::string join(const std::vector<std::string>& items, const std::string& sep) {
  std::string s;
  for (std::size_t i = 0; i < items.size(); ++i) s += (i ? sep : "") + items[i];
  return s;
}

}  // namespace

std::string ParamSpec::range_text() const {
  const std::string u = si_unit(unit).empty() ? "" : " " + si_unit(unit);
  if (min && max)
    return std::string("in ") + (min_exclusive ? "(" : "[") + number_text(*min) + ", " + number_text(*max) +
           (max_exclusive ? ")" : "]") + u;
  if (min) return std::string(min_exclusive ? "> " : ">= ") + number_text(*min) + u;
  if (max) return std::string(max_exclusive ? "< " : "<= ") + number_text(*max) + u;
  return "";
}

std::string ParamSpec::expected() const {
  const std::string u = si_unit(unit);
  const std::string q = unit == dim::none ? "number" : dimension_name(unit) + " (e.g. '1 " + u + "')";
  switch (type) {
    case ParamType::object: return "a map with keys " + join(child_names(), ", ");
    case ParamType::named_map: return "a map of named entries";
    case ParamType::list: return "a list";
    case ParamType::one_of: return "a map with exactly one of " + join(child_names(), ", ");
    case ParamType::number: return "a " + q;
    case ParamType::integer: return "an integer";
    case ParamType::boolean: return "true or false";
    case ParamType::string: return "a name";
    case ParamType::enumeration: return "one of " + join(choices, ", ");
    case ParamType::vector3: return "three values [x, y, z] of " + (unit == dim::none ? std::string("numbers") : q);
    case ParamType::vector3_pair: return "two corners [[x, y, z], [x, y, z]] of " + q;
    case ParamType::integer_list:
      return length ? "a list of " + std::to_string(length) + " integers" : "an integer or a list of integers";
    case ParamType::string_list: return length ? "a list of " + std::to_string(length) + " names" : "a list of names";
    case ParamType::path: return "a file path";
  }
  return "?";
}

namespace {

// pi / 2: the largest angle between two fibre families and their mean direction.
constexpr double kRightAngle = 1.57079632679489661923;

// Small builders so that the registry below reads like a table.
ParamSpec object(std::string name, std::string doc, std::vector<ParamSpec> fields) {
  ParamSpec p;
  p.name = std::move(name);
  p.type = ParamType::object;
  p.doc = std::move(doc);
  p.children = std::move(fields);
  return p;
}

ParamSpec one_of(std::string name, std::string doc, std::vector<ParamSpec> fields) {
  ParamSpec p = object(std::move(name), std::move(doc), std::move(fields));
  p.type = ParamType::one_of;
  return p;
}

ParamSpec named_map(std::string name, std::string doc, ParamSpec item) {
  ParamSpec p;
  p.name = std::move(name);
  p.type = ParamType::named_map;
  p.doc = std::move(doc);
  p.children = {std::move(item)};
  return p;
}

ParamSpec list(std::string name, std::string doc, ParamSpec item) {
  ParamSpec p = named_map(std::move(name), std::move(doc), std::move(item));
  p.type = ParamType::list;
  return p;
}

ParamSpec leaf(std::string name, ParamType type, std::string doc) {
  ParamSpec p;
  p.name = std::move(name);
  p.type = type;
  p.doc = std::move(doc);
  return p;
}

ParamSpec quantity(std::string name, Dimension unit, std::string doc) {
  ParamSpec p = leaf(std::move(name), ParamType::number, std::move(doc));
  p.unit = unit;
  return p;
}

ParamSpec vec3(std::string name, Dimension unit, std::string doc) {
  ParamSpec p = leaf(std::move(name), ParamType::vector3, std::move(doc));
  p.unit = unit;
  return p;
}

ParamSpec enumeration(std::string name, std::vector<std::string> choices, std::string doc) {
  ParamSpec p = leaf(std::move(name), ParamType::enumeration, std::move(doc));
  p.choices = std::move(choices);
  return p;
}

ParamSpec with_default(ParamSpec p, std::string value) {
  p.default_value = std::move(value);
  return p;
}

ParamSpec required(ParamSpec p) {
  p.required = true;
  return p;
}

ParamSpec above(ParamSpec p, double min, bool exclusive = true) {
  p.min = min;
  p.min_exclusive = exclusive;
  return p;
}

ParamSpec below(ParamSpec p, double max, bool exclusive = true) {
  p.max = max;
  p.max_exclusive = exclusive;
  return p;
}

ParamSpec region(std::string name, std::string doc) {
  ParamSpec box = leaf("box", ParamType::vector3_pair, "axis-aligned box [[xmin, ymin, zmin], [xmax, ymax, zmax]]");
  box.unit = dim::length;
  ParamSpec ids = above(leaf("ids", ParamType::integer_list, "explicit frame indices (0-based)"), 0, false);
  return one_of(std::move(name), std::move(doc),
                {
                    leaf("all", ParamType::boolean, "every frame of the object (write 'all: true')"),
                    box,
                    object("sphere", "ball around a centre",
                           {required(vec3("center", dim::length, "centre of the ball")),
                            required(above(quantity("radius", dim::length, "radius of the ball"), 0))}),
                    object("half_space", "points p with (p - point) . normal <= 0 (normal points out of it)",
                           {required(vec3("point", dim::length, "a point on the bounding plane")),
                            required(vec3("normal", dim::none, "outward normal of the half-space"))}),
                    ids,
                });
}

ParamSpec build_registry() {
  ParamSpec material = object(
      "material", "a hyperelastic material",
      {
          with_default(enumeration("law", {"stvk", "neo_hookean", "hgo"},
                                   "constitutive law: Saint Venant-Kirchhoff (paper eq. 19), compressible neo-Hookean, "
                                   "or hgo: a ground substance reinforced by one or two fibre families "
                                   "(Holzapfel-Gasser-Ogden, needs fibres)"),
                       "stvk"),
          enumeration("formulation", {"coupled", "uncoupled"},
                      "hgo only: coupled (the compressible neo-Hookean plus fibres on I1, I4; FEBio's 'HGO "
                      "unconstrained'; when absent) or uncoupled (mu/2 (I1bar - 3) + K/2 (ln J)^2 plus fibres on "
                      "I1bar, I4bar, K = E / (3 (1 - 2 nu)); FEBio's 'Holzapfel-Gasser-Ogden'), for nearly "
                      "incompressible tissue"),
          required(above(quantity("young", dim::pressure, "Young's modulus E (of the ground substance for hgo)"), 0)),
          with_default(below(above(quantity("poisson", dim::none, "Poisson ratio nu"), -1), 0.5), "0.3"),
          with_default(above(quantity("density", dim::density, "mass density rho"), 0), "1000 kg/m^3"),
          object("fibres",
                 "hgo: psi_f = k1/(2 k2) (exp(k2 <E_f>^2) - 1), E_f = kappa (I1 - 3) + (1 - 3 kappa)(I4 - 1), "
                 "in tension only",
                 {required(above(quantity("k1", dim::pressure, "fibre stiffness k1"), 0, false)),
                  required(above(quantity("k2", dim::none, "fibre exponent k2 (dimensionless)"), 0)),
                  with_default(below(above(quantity("dispersion", dim::none,
                                                    "fibre dispersion kappa: 0 aligned, 1/3 isotropic"),
                                           0, false),
                                     1.0 / 3, false),
                               "0"),
                  vec3("direction", dim::none,
                       "fibre direction at rest, world axes (normalised); objects may give their own (object fibres); "
                       "with two families their mean direction"),
                  with_default(below(above(leaf("families", ParamType::integer,
                                                "fibre families: 1 along the direction, or 2 at +-angle about it "
                                                "in the plane of direction and plane"),
                                           1, false),
                                     2, false),
                               "1"),
                  below(above(quantity("angle", dim::none,
                                       "two families: their angle gamma to the direction, e.g. '30 deg' (SI: rad)"),
                              0, false),
                        kRightAngle, false),
                  vec3("plane", dim::none,
                       "two families: a vector of their plane, not parallel to the direction (as FEBio's mat_axis "
                       "d): the families run at cos(angle) e1 +- sin(angle) e2, e2 its unit part orthogonal to the "
                       "direction e1")}),
      });
  ParamSpec fibre_region = object("fibre_region", "fibres of the samples in a region",
                                  {required(region("region", "which samples (rest positions, world axes)")),
                                   required(vec3("direction", dim::none, "their fibre direction (normalised)"))});

  ParamSpec cells = above(leaf("cells", ParamType::integer_list, "number of cells along x, y, z"), 1, false);
  cells.length = 3;
  cells.default_value = "[1, 1, 1]";
  ParamSpec between = leaf("between", ParamType::string_list,
                           "[a, b]: meshless tissue filling the space within 'within' of both organs' rest "
                           "surfaces, outside both; its frames near each organ are shared with it (attached to a "
                           "rigid body)");
  between.length = 2;
  ParamSpec obj = object(
      "object", "a simulated object",
      {
          with_default(enumeration("kind", {"tissue", "shell", "rigid"},
                                   "tissue: volumetric frame-based body; shell: thin wall; rigid: bone or tool"),
                       "tissue"),
          leaf("material", ParamType::string, "name of an entry of materials"),
          leaf("mesh", ParamType::path,
               "volume mesh, mesh-based tissue: legacy VTK (.vtk, tetra/hexa) or Gmsh 2.2 ASCII (.msh)"),
          object("box", "a generated box meshed with a regular grid (mesh-based tissue)",
                 {required(vec3("min", dim::length, "lower corner")), required(vec3("max", dim::length, "upper corner")),
                  cells,
                  with_default(enumeration("elements", {"hex", "tet"}, "hexahedra, or each split in 6 tetrahedra"),
                               "hex")}),
          leaf("surface", ParamType::path, "closed surface mesh: meshless tissue, shell or rigid body"),
          leaf("image", ParamType::path,
               "label image, meshless tissue: NIfTI-1/2 (.nii, .nii.gz) or NRRD (.nrrd, .seg.nrrd), placed by its "
               "own spacing, origin and orientation (RAS+ world axes, the file's millimetres read as metres x 1e-3)"),
          leaf("label", ParamType::integer_list,
               "with image: the label of the voxels that form the object, or a list of labels (their union)"),
          above(quantity("smoothing", dim::length,
                         "with image: standard deviation of the smoothing of the voxels' boundary (repeated mean "
                         "filters of its level set); 0 keeps the voxels' faces"),
                0, false),
          between,
          above(quantity("within", dim::length, "with between: the largest distance from each organ"), 0),
          region("region", "with between: only the tissue's points in this region (box, sphere or half_space; rest "
                           "positions, world axes)"),
          object("discretisation", "how the object is turned into frames and samples",
                 {with_default(below(above(leaf("quadrature", ParamType::integer,
                                                "samples per element: tet 1 or 4, hex 1, 8 or 27 (0 = tet 4, hex 8)"),
                                           0, false),
                                     27, false),
                               "0"),
                  object("meshless", "meshless discretisation of a closed surface",
                         {required(above(quantity("frame_spacing", dim::length, "Poisson-disk radius of frames"), 0)),
                          required(above(quantity("sample_spacing", dim::length, "Poisson-disk radius of samples (the quadrature: the frames do not depend on it)"), 0)),
                          with_default(enumeration("shape", {"mls"}, "meshless shape functions: moving least squares with a linear basis (conforming, one field per frame)"), "mls"),
                          with_default(above(leaf("neighbours", ParamType::integer,
                                                  "each frame's support radius is 1.6 times the distance to its k-th nearest frame: k"),
                                             1, false),
                                       "8"),
                          with_default(below(above(leaf("seed", ParamType::integer, "Poisson-disk seed (same seed, same frames and samples)"), 0, false),
                                             9007199254740992.0, false),  // 2^53: exact as a double
                                       "1"),
                          with_default(enumeration("thin_parts", {"repair", "stop"},
                                                   "parts thinner than frame_spacing: add frames across them, or stop with the thickness and the spacing that resolves it"),
                                       "repair")})}),
          object("transform", "applied to the geometry before discretisation: scale, then rotate, then translate",
                 {with_default(above(quantity("scale", dim::none, "uniform scale factor"), 0), "1"),
                  with_default(vec3("rotate", dim::none, "rotations about x, then y, then z (radians; '90 deg' works)"),
                               "[0, 0, 0]"),
                  with_default(vec3("translate", dim::length, "translation"), "[0, 0, 0]")}),
          with_default(leaf("lock_rotations", ParamType::boolean,
                            "frames as 3-DOF nodes (R = I): classic FEM, the paper's Figure 3 baseline"),
                       "false"),
          above(quantity("thickness", dim::length, "shell: wall thickness (required for shells)"), 0),
          above(quantity("density", dim::density,
                         "rigid body density (mass and inertia of the closed surface; default: the material's, "
                         "else 1000 kg/m^3)"),
                0),
          with_default(leaf("fixed", ParamType::boolean,
                            "rigid body held in place (move one instead with a motion load, region all: true)"),
                       "false"),
          one_of("fibres", "tissue of an hgo material: where its fibres run, instead of the material's direction",
                 {vec3("direction", dim::none, "one direction for the whole object (rest, world axes; normalised)"),
                  leaf("from", ParamType::string,
                       "with between: one of the two organs; the fibres follow the gradient of the distance to it "
                       "(from one organ across to the other)"),
                  list("regions", "per region: the first region holding a sample gives its direction, the "
                                  "material's direction elsewhere",
                       fibre_region)}),
      });

  ParamSpec constraint =
      object("constraint", "frames held at their rest position",
             {required(leaf("fix", ParamType::string, "object whose frames are fixed")),
              required(region("region", "which frames (rest positions, world axes)")),
              with_default(leaf("translations_only", ParamType::boolean, "fix translations only, rotations stay free"),
                           "false")});

  auto selection = [](std::vector<ParamSpec> extra) {
    std::vector<ParamSpec> fields = {required(leaf("object", ParamType::string, "object the load acts on")),
                                     required(region("region", "which frames or boundary faces (rest positions)"))};
    for (ParamSpec& e : extra) fields.push_back(std::move(e));
    return fields;
  };
  ParamSpec load = one_of(
      "load", "an external load",
      {
          vec3("gravity", dim::acceleration, "gravitational acceleration"),
          object("point_force", "a constant force shared equally by the frames of a region",
                 selection({required(vec3("force", dim::force, "total force"))})),
          object("surface_force", "a constant traction on the boundary faces whose centre lies in a region",
                 selection({required(vec3("traction", dim::pressure, "force per unit rest area"))})),
          object("motion",
                 "frames moved rigidly between start and end, then held (a tool pulling, a bone flexing about a "
                 "joint)",
                 selection({required(vec3("velocity", dim::velocity, "velocity of the frames (and of the pivot)")),
                            vec3("angular_velocity", dim::frequency,
                                 "rotation rate about the pivot, world axes, e.g. [0, 0, 20 deg/s] (SI: rad/s); "
                                 "prescribes the frames' rotations too"),
                            vec3("pivot", dim::length,
                                 "centre of the rotation at rest (default: a rigid body's centre of mass, else "
                                 "the centroid of the selected frames)"),
                            with_default(above(quantity("start", dim::time, "start time"), 0, false), "0 s"),
                            above(quantity("end", dim::time, "end time (default: never)"), 0)})),
      });

  ParamSpec share = leaf("share", ParamType::string_list, "two objects that share frames where they overlap");
  share.length = 2;
  share.doc = "[a, b]: frames of a within 'within' of b's rest surface become b's nearest frames (put the "
              "tissue first, the shell second)";
  ParamSpec coupling = object(
      "coupling", "a mechanical coupling between objects (paper §4.2): share frames, or attach to a rigid body",
      {share, leaf("attach", ParamType::string, "object whose frames near the rigid body follow it"),
       leaf("to", ParamType::string, "the rigid body it is attached to"),
       with_default(above(quantity("within", dim::length,
                                   "distance from a frame's rest position to the other object's rest surface"),
                          0),
                    "2 mm")});

  ParamSpec solver = object(
      "solver", "time integration and nonlinear solver",
      {
          with_default(enumeration("integrator", {"static", "backward_euler", "variational"},
                                   "static equilibrium (Newton on W - f.x), backward Euler (dissipative), or "
                                   "variational (midpoint discrete Lagrangian: conserves momenta, no damping)"),
                       "backward_euler"),
          with_default(above(quantity("dt", dim::time, "time step (static: pseudo-time per step)"), 0), "10 ms"),
          with_default(above(quantity("rayleigh_mass", dim::frequency,
                                      "Rayleigh damping alpha (D = alpha M + beta K; backward_euler only)"),
                             0, false),
                       "0"),
          with_default(above(quantity("rayleigh_stiffness", dim::time, "Rayleigh damping beta (backward_euler only)"), 0, false), "0"),
          with_default(above(leaf("load_steps", ParamType::integer, "static: initial number of load increments"), 1,
                             false),
                       "1"),
          with_default(above(leaf("max_load_halvings", ParamType::integer,
                                  "static: the smallest load increment is the first halved this many times"),
                             0, false),
                       "10"),
          with_default(above(leaf("threads", ParamType::integer, "CPU threads of the step (0 = one per 500 samples and shell triangles, at most the cores; one fewer, left to the rows, where that is every core of several, under 1,000 per core, with a row after each fixed dynamic step)"), 0, false), "0"),
          object("adaptive",
                 "backward_euler, static: adaptive time steps, dt the first; a step whose Newton fails or whose "
                 "error exceeds the tolerance is retried smaller, easy steps grow; output rows stay at the "
                 "multiples of output.every x dt (docs/solvers.md)",
                 {required(above(quantity("tolerance", dim::length,
                                          "error per step: backward_euler (h/2)|v_{n+1} - v_n|, static the increment "
                                          "|x_{n+1} - x_n|, on the free frames, rotations times the model's extent"),
                                 0)),
                  with_default(above(quantity("min_dt", dim::time,
                                              "smallest step; a step whose Newton fails at min_dt stops the run"),
                                     0),
                               "1e-6 s"),
                  above(quantity("max_dt", dim::time, "largest step (default: none below the output interval)"), 0)}),
          object("newton", "Newton with backtracking line search",
                 {with_default(above(quantity("tolerance", dim::none, "relative residual force to stop at"), 0),
                               "1e-6"),
                  with_default(above(leaf("max_iterations", ParamType::integer, "Newton iterations per step"), 1,
                                     false),
                               "50"),
                  with_default(above(leaf("max_backtracks", ParamType::integer, "step halvings in the line search"),
                                     0, false),
                               "30"),
                  with_default(above(leaf("fixed_iterations", ParamType::integer,
                                          "exactly this many iterations, no line search (0 = off; benchmarks)"),
                                     0, false),
                               "0")}),
          object("linear", "linear solver of each Newton step",
                 {with_default(enumeration("method", {"cg", "pcg", "cholmod"},
                                           "conjugate gradients, preconditioned CG, or a CHOLMOD direct solve"),
                               "pcg"),
                  with_default(enumeration("preconditioner", {"block_jacobi", "cholmod"},
                                           "pcg's preconditioner (method pcg only): the 6x6 diagonal blocks, or a sparse "
                                           "factorisation of the tangent reused across Newton iterations and steps"),
                               "cholmod"),
                  with_default(above(quantity("tolerance", dim::none, "CG relative residual"), 0), "1e-8"),
                  with_default(above(leaf("max_iterations", ParamType::integer, "CG iteration cap"), 1, false),
                               "2000"),
                  with_default(leaf("fixed_iterations", ParamType::boolean,
                                    "run exactly max_iterations CG iterations (the paper's 60)"),
                               "false")}),
      });

  ParamSpec run = object("run", "how long to simulate",
                         {above(quantity("duration", dim::time, "simulated time (steps = duration / dt)"), 0),
                          above(leaf("steps", ParamType::integer, "number of steps (default: 1 for static)"), 1, false)});

  ParamSpec output = object(
      "output", "the HDF5 trajectory",
      {leaf("file", ParamType::string, "output file (default: the scene's name with .h5, in the working directory)"),
       with_default(above(leaf("every", ParamType::integer, "write every n-th step"), 1, false), "1"),
       with_default(leaf("samples", ParamType::boolean,
                         "write the samples: positions and fields (228 bytes per sample and step: 9 doubles, "
                         "39 floats; false keeps frames and surfaces)"),
                    "true"),
       with_default(leaf("xdmf", ParamType::boolean, "write the XDMF sidecar for ParaView"), "true"),
       object("checkpoint", "the state to continue the run from (fascia run --resume; docs/hpc.md)",
              {with_default(above(leaf("every", ParamType::integer,
                                       "write a checkpoint every n-th step (0 = only by interval, on a stop and at the end)"),
                                  0, false),
                            "0"),
               with_default(above(quantity("interval", dim::time,
                                           "wall-clock time between checkpoints (0 = only by step count, on a stop and at the end)"),
                                  0, false),
                            "10 min")})});

  ParamSpec include = leaf("include", ParamType::string_list,
                           "scenes merged under this one (paths relative to this file; this file wins)");
  ParamSpec extends = include;
  extends.name = "extends";

  return object("scene", "a fascia scene",
                {with_default(below(above(leaf("fascia", ParamType::integer, "scene language version"), 1, false),
                                    kSceneLanguageVersion, false),
                              std::to_string(kSceneLanguageVersion)),
                 include, extends, named_map("materials", "materials by name", material),
                 named_map("objects", "objects by name", obj), list("constraints", "fixed frames", constraint),
                 list("loads", "external loads and prescribed motions", load),
                 list("couplings", "couplings between objects", coupling), solver, run, output});
}

}  // namespace

const ParamSpec& scene_registry() {
  static const ParamSpec root = build_registry();
  return root;
}

}  // namespace fascia::dsl
