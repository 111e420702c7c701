#include "dsl/scene_spec.hpp"

#include "dsl/source_tree.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <stdexcept>

namespace fascia::dsl {

namespace fs = std::filesystem;

bool RegionSpec::contains(const Vec3d& p, double tolerance) const {
  switch (kind) {
    case Kind::all: return true;
    case Kind::box:
      for (int k = 0; k < 3; ++k)
        if (p[k] < lo[k] - tolerance || p[k] > hi[k] + tolerance) return false;
      return true;
    case Kind::sphere: {
      double d2 = 0;
      for (int k = 0; k < 3; ++k) d2 += (p[k] - center[k]) * (p[k] - center[k]);
      return std::sqrt(d2) <= radius + tolerance;
    }
    case Kind::half_space: {
      double d = 0, n2 = 0;
      for (int k = 0; k < 3; ++k) {
        d += (p[k] - point[k]) * normal[k];
        n2 += normal[k] * normal[k];
      }
      return d / std::sqrt(n2) <= tolerance;
    }
    case Kind::ids: return false;  // explicit ids select by index, not by position
  }
  return false;
}

double RegionSpec::signed_distance(const Vec3d& p) const {
  switch (kind) {
    case Kind::all: return -std::numeric_limits<double>::infinity();
    case Kind::box: {
      // Outside: the length of the excess beyond the faces; inside: minus the depth below the
      // nearest face.
      double outside2 = 0, inside = -std::numeric_limits<double>::infinity();
      for (int k = 0; k < 3; ++k) {
        const double q = std::max(lo[k] - p[k], p[k] - hi[k]);
        outside2 += q > 0 ? q * q : 0;
        inside = std::max(inside, std::min(q, 0.0));
      }
      return outside2 > 0 ? std::sqrt(outside2) : inside;
    }
    case Kind::sphere: {
      double d2 = 0;
      for (int k = 0; k < 3; ++k) d2 += (p[k] - center[k]) * (p[k] - center[k]);
      return std::sqrt(d2) - radius;
    }
    case Kind::half_space: {
      double d = 0, n2 = 0;
      for (int k = 0; k < 3; ++k) {
        d += (p[k] - point[k]) * normal[k];
        n2 += normal[k] * normal[k];
      }
      return d / std::sqrt(n2);
    }
    case Kind::ids: break;
  }
  throw std::logic_error("RegionSpec::signed_distance: ids select frames, not points");
}

Vec3d TransformSpec::apply(const Vec3d& p) const {
  Vec3d q{scale * p[0], scale * p[1], scale * p[2]};
  auto rot = [&q](int a, int b, double angle) {
    const double c = std::cos(angle), s = std::sin(angle);
    const double qa = c * q[a] - s * q[b], qb = s * q[a] + c * q[b];
    q[a] = qa;
    q[b] = qb;
  };
  rot(1, 2, rotate[0]);  // about x
  rot(2, 0, rotate[1]);  // about y
  rot(0, 1, rotate[2]);  // about z
  return {q[0] + translate[0], q[1] + translate[1], q[2] + translate[2]};
}

const MaterialSpec* SceneSpec::material(const std::string& name) const {
  for (const MaterialSpec& m : materials)
    if (m.name == name) return &m;
  return nullptr;
}

const ObjectSpec* SceneSpec::object(const std::string& name) const {
  for (const ObjectSpec& o : objects)
    if (o.name == name) return &o;
  return nullptr;
}

namespace {

template <class T>
Located<T> located(const T& value, const Value& v) {
  return Located<T>{value, v.where};
}

Located<std::string> located_str(const Value& v) { return {v.text, v.where}; }
Located<double> located_num(const Value& v) { return {v.number, v.where}; }

RegionSpec region_from(const Value& v, Diagnostics& diagnostics) {
  RegionSpec r;
  r.where = v.where;
  if (v.fields.empty()) return r;
  const auto& [key, value] = v.fields.front();
  if (key == "all") {
    r.kind = RegionSpec::Kind::all;
    if (!value.boolean) diagnostics.error(value.where, "region 'all: false' selects nothing; write 'all: true'");
  } else if (key == "box") {
    r.kind = RegionSpec::Kind::box;
    r.lo = value.items[0].vec3();
    r.hi = value.items[1].vec3();
    for (int k = 0; k < 3; ++k) {
      if (r.lo[k] > r.hi[k]) {
        diagnostics.error(value.where, "region box: the first corner must be the lower one (min <= max on every axis)");
        break;
      }
    }
  } else if (key == "sphere") {
    r.kind = RegionSpec::Kind::sphere;
    r.center = value.at("center").vec3();
    r.radius = value.num("radius");
  } else if (key == "half_space") {
    r.kind = RegionSpec::Kind::half_space;
    r.point = value.at("point").vec3();
    r.normal = value.at("normal").vec3();
    if (r.normal[0] == 0 && r.normal[1] == 0 && r.normal[2] == 0)
      diagnostics.error(value.at("normal").where, "half_space normal must not be zero");
  } else if (key == "ids") {
    r.kind = RegionSpec::Kind::ids;
    for (const Value& i : value.items) r.ids.push_back(static_cast<int>(i.integer));
    if (r.ids.empty()) diagnostics.error(value.where, "region ids: the list is empty, it selects nothing");
  }
  return r;
}

// A fibre direction: nonzero (it is normalised when built).
Located<Vec3d> fibre_direction(const Value& v, Diagnostics& diagnostics) {
  const Located<Vec3d> d = located(v.vec3(), v);
  if (!(std::abs(d.value[0]) + std::abs(d.value[1]) + std::abs(d.value[2]) > 0))
    diagnostics.error(v.where, "a fibre direction must not be zero");
  return d;
}

// Two fibre families need their angle and plane (not parallel to a material direction), one
// family neither.
void check_fibre_families(const FibresSpec& f, Diagnostics& diagnostics) {
  if (f.families.value == 1) {
    if (f.angle) diagnostics.error(f.angle->where, "fibres.angle places two families: give families: 2, or drop it");
    if (f.plane) diagnostics.error(f.plane->where, "fibres.plane places two families: give families: 2, or drop it");
    return;
  }
  if (!f.angle || !f.plane) {
    diagnostics.error(f.families.where, std::string("two fibre families need their ") +
                                            (!f.angle && !f.plane ? "angle and plane"
                                             : !f.angle          ? "angle"
                                                                 : "plane") +
                                            " (fibres.angle: their angle to the direction, fibres.plane: a vector "
                                            "of their plane)");
    return;
  }
  const Vec3d& p = f.plane->value;
  const double pn = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
  if (!(pn > 0)) {
    diagnostics.error(f.plane->where, "fibres.plane must not be zero");
    return;
  }
  if (!f.direction) return;  // the objects' directions are checked when built
  const Vec3d& d = f.direction->value;
  const double dn = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  if (!(dn > 0)) return;  // reported as a zero direction
  // |d x p| / (|d| |p|): the sine of their angle (as with_fibre_direction, material.cpp).
  const double cx = d[1] * p[2] - d[2] * p[1], cy = d[2] * p[0] - d[0] * p[2], cz = d[0] * p[1] - d[1] * p[0];
  if (!(std::sqrt(cx * cx + cy * cy + cz * cz) > 1e-6 * dn * pn))
    diagnostics.error(f.plane->where, "fibres.plane is parallel to fibres.direction: it must span the families' "
                                      "plane with it");
}

std::vector<std::string> names_of(const std::vector<MaterialSpec>& m) {
  std::vector<std::string> out;
  for (const MaterialSpec& x : m) out.push_back(x.name);
  return out;
}

std::vector<std::string> names_of(const std::vector<ObjectSpec>& o) {
  std::vector<std::string> out;
  for (const ObjectSpec& x : o) out.push_back(x.name);
  return out;
}

void check_object_ref(const SceneSpec& scene, const Located<std::string>& ref, Diagnostics& diagnostics) {
  if (scene.object(ref.value)) return;
  diagnostics.error(ref.where, "unknown object '" + ref.value + "'" + did_you_mean(ref.value, names_of(scene.objects)) +
                                   (scene.objects.empty() ? "; the scene defines no objects" : ""));
}

// Builds the SceneSpec from the validated tree and cross-checks it. With `partial` (the tree had
// errors, so some values are missing) only references between sections are checked: the other
// checks would report consequences of the errors already found.
SceneSpec extract(const Value& root, const std::string& file, Diagnostics& diagnostics, bool partial) {
  SceneSpec scene;
  scene.file = file;
  scene.resolved = root;

  if (const Value* materials = root.find("materials")) {
    for (const auto& [name, m] : materials->fields) try {
      MaterialSpec spec;
      spec.name = name;
      spec.where = m.where;
      spec.law = located_str(m.at("law"));
      if (m.has("young")) spec.young = located_num(m.at("young"));
      spec.poisson = located_num(m.at("poisson"));
      spec.density = located_num(m.at("density"));
      if (const Value* f = m.find("fibres")) {
        FibresSpec fibres;
        fibres.where = f->where;
        fibres.k1 = located_num(f->at("k1"));
        fibres.k2 = located_num(f->at("k2"));
        fibres.dispersion = located_num(f->at("dispersion"));
        if (const Value* d = f->find("direction")) fibres.direction = fibre_direction(*d, diagnostics);
        fibres.families = {static_cast<int>(f->integer_at("families")), f->at("families").where};
        if (const Value* a = f->find("angle")) fibres.angle = located_num(*a);
        if (const Value* p = f->find("plane")) fibres.plane = located(p->vec3(), *p);
        if (!partial) check_fibre_families(fibres, diagnostics);
        spec.fibres = fibres;
      }
      if (const Value* form = m.find("formulation")) {
        spec.formulation = located_str(*form);
        if (spec.law.value != "hgo")
          diagnostics.error(form->where, "'formulation' belongs to law hgo; material '" + name + "' is " +
                                             spec.law.value);
      }
      if (spec.law.value == "hgo" && !spec.fibres)
        diagnostics.error(spec.law.where, "law hgo needs 'fibres' in material '" + name + "': k1, k2 and optionally "
                                          "dispersion and direction");
      else if (spec.law.value != "hgo" && spec.fibres)
        diagnostics.error(spec.fibres->where, "'fibres' belong to law hgo; material '" + name + "' is " + spec.law.value);
      scene.materials.push_back(spec);
    } catch (const std::logic_error&) {
      // incomplete after validation errors
    }
  }

  if (const Value* objects = root.find("objects")) {
    for (const auto& [name, o] : objects->fields) try {
      // Names become HDF5 groups (/particles/<name>) and --set path segments.
      if (name == "frames" || name == "samples")
        diagnostics.error(o.where, "object name '" + name + "' is reserved for the output's own " + name +
                                       "; choose another name");
      else if (name.empty() || name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-") !=
                                   std::string::npos)
        diagnostics.error(o.where, "object name '" + name + "': use letters, digits, '_' and '-' only");
      ObjectSpec spec;
      spec.name = name;
      spec.where = o.where;
      spec.kind = located_str(o.at("kind"));
      if (o.has("material")) spec.material = located_str(o.at("material"));
      if (o.has("mesh")) spec.mesh = located_str(o.at("mesh"));
      if (o.has("surface")) spec.surface = located_str(o.at("surface"));
      if (o.has("image")) spec.image = located_str(o.at("image"));
      if (const Value* between = o.find("between"))
        for (const Value& b : between->items) spec.between.push_back(located_str(b));
      if (o.has("within")) spec.within = located_num(o.at("within"));
      if (o.has("smoothing")) spec.smoothing = located_num(o.at("smoothing"));
      if (const Value* region = o.find("region"); region && !region->fields.empty()) {
        spec.region = region_from(*region, diagnostics);
        if (spec.region->kind == RegionSpec::Kind::ids)
          diagnostics.error(spec.region->where, "the region of a tissue between organs selects points by position; "
                                                "ids select frames: use box, sphere, half_space or all");
      }
      if (const Value* label = o.find("label")) {
        Located<std::vector<int>> labels{{}, label->where};
        for (const Value& item : label->items) labels.value.push_back(static_cast<int>(item.integer));
        spec.label = labels;
      }
      if (const Value* box = o.find("box")) {
        BoxSpec b;
        b.min = located(box->at("min").vec3(), box->at("min"));
        b.max = located(box->at("max").vec3(), box->at("max"));
        const Value& cells = box->at("cells");
        b.cells.where = cells.where;
        for (std::size_t k = 0; k < 3 && k < cells.items.size(); ++k)
          b.cells.value[k] = static_cast<int>(cells.items[k].integer);
        b.elements = located_str(box->at("elements"));
        for (int k = 0; k < 3; ++k) {
          if (!(b.min.value[k] < b.max.value[k])) {
            diagnostics.error(b.max.where, "box max must be greater than min on every axis");
            break;
          }
        }
        spec.box = b;
      }
      const Value& disc = o.at("discretisation");
      spec.quadrature = {static_cast<int>(disc.integer_at("quadrature")), disc.at("quadrature").where};
      if (const Value* meshless = disc.find("meshless")) {
        spec.meshless = MeshlessSpec{located_num(meshless->at("frame_spacing")),
                                     located_num(meshless->at("sample_spacing")),
                                     located_str(meshless->at("shape")),
                                     {static_cast<int>(meshless->integer_at("neighbours")), meshless->at("neighbours").where},
                                     {meshless->integer_at("seed"), meshless->at("seed").where},
                                     located_str(meshless->at("thin_parts"))};
      }
      const Value& transform = o.at("transform");
      spec.transform.scale = transform.num("scale");
      spec.transform.rotate = transform.at("rotate").vec3();
      spec.transform.translate = transform.at("translate").vec3();
      spec.lock_rotations = o.flag("lock_rotations");
      if (o.has("thickness")) spec.thickness = located_num(o.at("thickness"));
      if (o.has("density")) spec.density = located_num(o.at("density"));
      if (o.has("fixed")) spec.fixed = Located<bool>{o.flag("fixed"), o.at("fixed").where};
      if (const Value* f = o.find("fibres"); f && !f->fields.empty()) {
        ObjectFibresSpec fibres;
        fibres.where = f->where;
        const auto& [key, value] = f->fields.front();
        if (key == "direction") {
          fibres.direction = fibre_direction(value, diagnostics);
        } else if (key == "from") {
          fibres.from = located_str(value);
        } else if (key == "regions") {
          for (const Value& r : value.items) {
            ObjectFibresSpec::Region region{region_from(r.at("region"), diagnostics),
                                            fibre_direction(r.at("direction"), diagnostics)};
            if (region.region.kind == RegionSpec::Kind::ids)
              diagnostics.error(region.region.where, "fibre regions select samples by their rest position; ids "
                                                     "select frames: use box, sphere, half_space or all");
            fibres.regions.push_back(region);
          }
          if (fibres.regions.empty()) diagnostics.error(value.where, "fibres.regions: the list is empty");
        }
        spec.fibres = fibres;
      }

      // Which geometry: exactly one source per object.
      const int sources = (spec.mesh ? 1 : 0) + (spec.box ? 1 : 0) + (spec.surface ? 1 : 0) + (spec.image ? 1 : 0) +
                          (spec.between.empty() ? 0 : 1);
      if (partial) {
        // skip: geometry keys may have been dropped by validation errors
      } else if (sources == 0 && spec.kind.value == "tissue") {
        diagnostics.error(o.where, "object '" + name + "' has no geometry: give one of mesh, box, surface, image or between");
      } else if (sources > 1) {
        diagnostics.error(o.where, "object '" + name + "' has several geometries: give only one of mesh, box, surface, image, between");
      }
      if (partial) {
      } else if (spec.image && !spec.label) {
        diagnostics.error(spec.image->where, "object '" + name + "' from a label image needs 'label': the label "
                                                                 "(or list of labels) of the voxels that form it");
      } else if (spec.label && !spec.image) {
        diagnostics.error(spec.label->where, "'label' selects voxels of a label image: object '" + name +
                                                 "' needs 'image' too");
      } else if (!spec.between.empty() && !spec.within) {
        diagnostics.error(spec.between.front().where, "object '" + name + "' between two organs needs 'within': the "
                                                                          "largest distance from each");
      } else if (spec.within && spec.between.empty()) {
        diagnostics.error(spec.within->where, "'within' is the distance of a tissue between two organs: object '" +
                                                  name + "' needs 'between' too");
      } else if (!spec.between.empty() && spec.kind.value != "tissue") {
        diagnostics.error(spec.between.front().where, "'between' makes a tissue; '" + name + "' is a " + spec.kind.value);
      } else if (spec.region && spec.between.empty()) {
        diagnostics.error(spec.region->where, "'region' restricts a tissue between two organs: object '" + name +
                                                  "' needs 'between' too");
      } else if (spec.smoothing && !spec.image) {
        diagnostics.error(spec.smoothing->where, "'smoothing' smooths the voxels of a label image: object '" + name +
                                                     "' needs 'image' too");
      } else if (spec.image && spec.kind.value != "tissue") {
        diagnostics.error(spec.image->where, "a label image gives the geometry of tissues only; '" + name + "' is a " +
                                                 spec.kind.value);
      }
      if (partial) {
      } else if (spec.kind.value == "tissue") {
        if (!spec.material) diagnostics.error(o.where, "tissue object '" + name + "' needs a material");
        if (spec.surface && !spec.meshless)
          diagnostics.error(spec.surface->where, "tissue '" + name +
                                                     "' from a surface needs discretisation.meshless settings "
                                                     "(frame_spacing, sample_spacing)");
        if (!spec.between.empty() && !spec.meshless)
          diagnostics.error(spec.between.front().where, "tissue '" + name +
                                                            "' between two organs needs discretisation.meshless "
                                                            "settings (frame_spacing, sample_spacing)");
        if (spec.image && !spec.meshless)
          diagnostics.error(spec.image->where, "tissue '" + name +
                                                   "' from a label image needs discretisation.meshless settings "
                                                   "(frame_spacing, sample_spacing)");
      } else if (spec.kind.value == "shell") {
        if (!spec.surface) diagnostics.error(o.where, "shell '" + name + "' needs a surface");
        if (!spec.thickness) diagnostics.error(o.where, "shell '" + name + "' needs a thickness");
        if (!spec.material) diagnostics.error(o.where, "shell '" + name + "' needs a material");
      } else if (spec.kind.value == "rigid") {
        if (!spec.surface) diagnostics.error(o.where, "rigid object '" + name + "' needs a surface");
      }
      scene.objects.push_back(spec);
    } catch (const std::logic_error&) {
      // incomplete after validation errors; keep the name for reference checks
      ObjectSpec spec;
      spec.name = name;
      spec.where = o.where;
      scene.objects.push_back(spec);
    }
  }

  for (const ObjectSpec& o : scene.objects) {
    const MaterialSpec* material = o.material ? scene.material(o.material->value) : nullptr;
    if (o.material && !material) {
      diagnostics.error(o.material->where, "unknown material '" + o.material->value + "'" +
                                               did_you_mean(o.material->value, names_of(scene.materials)) +
                                               (scene.materials.empty() ? "; the scene defines no materials" : ""));
    }
    if (partial) continue;
    const bool hgo = material && material->law.value == "hgo" && material->fibres;
    if (o.fibres && (!hgo || o.kind.value != "tissue")) {
      diagnostics.error(o.fibres->where, "'fibres' place the fibres of a tissue of an hgo material; object '" + o.name +
                                             "' is " + (o.kind.value != "tissue" ? "a " + o.kind.value
                                                        : material ? "of law " + material->law.value
                                                                   : std::string("without a material")));
    } else if (o.fibres && o.fibres->from) {
      const Located<std::string>& organ = *o.fibres->from;
      if (o.between.empty())
        diagnostics.error(organ.where, "fibres.from follows the distance to an organ that the tissue lies "
                                         "between; object '" + o.name + "' has no 'between'");
      else if (organ.value != o.between[0].value && (o.between.size() < 2 || organ.value != o.between[1].value))
        diagnostics.error(organ.where, "fibres.from: '" + organ.value + "' is not one of the organs '" + o.name +
                                             "' lies between (" + o.between[0].value +
                                             (o.between.size() > 1 ? ", " + o.between[1].value : std::string()) + ")");
    } else if (hgo && o.kind.value == "tissue" && !material->fibres->direction &&
               !(o.fibres && (o.fibres->direction || o.fibres->from))) {
      diagnostics.error(o.fibres ? o.fibres->where : o.where,
                        "object '" + o.name + "' of hgo material '" + material->name + "' has no fibre direction" +
                            (o.fibres ? " outside its fibre regions" : "") +
                            ": give fibres.direction in the material, or fibres (direction or from) in the object");
    } else if (hgo && o.kind.value == "shell") {
      diagnostics.error(o.material->where, "shells take an isotropic material; '" + material->name + "' is hgo");
    }
  }

  if (const Value* constraints = root.find("constraints")) {
    for (const Value& c : constraints->items) try {
      ConstraintSpec spec;
      spec.where = c.where;
      spec.object = located_str(c.at("fix"));
      spec.region = region_from(c.at("region"), diagnostics);
      spec.translations_only = c.flag("translations_only");
      check_object_ref(scene, spec.object, diagnostics);
      scene.constraints.push_back(spec);
    } catch (const std::logic_error&) {
    }
  }

  if (const Value* loads = root.find("loads")) {
    for (const Value& l : loads->items) try {
      if (l.fields.empty()) continue;
      const auto& [key, value] = l.fields.front();
      LoadSpec spec;
      spec.where = l.where;
      if (key == "gravity") {
        spec.kind = LoadSpec::Kind::gravity;
        spec.vector = located(value.vec3(), value);
      } else {
        spec.kind = key == "point_force"     ? LoadSpec::Kind::point_force
                    : key == "surface_force" ? LoadSpec::Kind::surface_force
                                             : LoadSpec::Kind::motion;
        spec.object = located_str(value.at("object"));
        spec.region = region_from(value.at("region"), diagnostics);
        const char* vector_key = spec.kind == LoadSpec::Kind::point_force     ? "force"
                                 : spec.kind == LoadSpec::Kind::surface_force ? "traction"
                                                                              : "velocity";
        spec.vector = located(value.at(vector_key).vec3(), value.at(vector_key));
        if (spec.kind == LoadSpec::Kind::motion) {
          if (value.has("angular_velocity"))
            spec.angular_velocity = located(value.at("angular_velocity").vec3(), value.at("angular_velocity"));
          if (value.has("pivot")) {
            spec.pivot = located(value.at("pivot").vec3(), value.at("pivot"));
            if (!spec.angular_velocity)
              diagnostics.error(value.at("pivot").where, "motion: a pivot needs an angular_velocity to rotate about it");
          }
          spec.start = value.num("start");
          if (value.has("end")) {
            spec.end = value.num("end");
            if (!(*spec.end > spec.start))
              diagnostics.error(value.at("end").where, "motion end must be after start");
          }
        }
        if (spec.kind == LoadSpec::Kind::surface_force && spec.region->kind == RegionSpec::Kind::ids)
          diagnostics.error(spec.region->where, "surface_force selects boundary faces by position; ids are not allowed");
        check_object_ref(scene, *spec.object, diagnostics);
      }
      scene.loads.push_back(spec);
    } catch (const std::logic_error&) {
    }
  }

  if (const Value* couplings = root.find("couplings")) {
    for (const Value& c : couplings->items) try {
      CouplingSpec spec;
      spec.where = c.where;
      if (const Value* share = c.find("share"))
        for (const Value& s : share->items) spec.share.push_back(located_str(s));
      if (c.has("attach")) spec.attach = located_str(c.at("attach"));
      if (c.has("to")) spec.to = located_str(c.at("to"));
      if (c.has("within")) spec.within = located_num(c.at("within"));
      const bool is_share = !spec.share.empty(), is_attach = spec.attach.has_value() || spec.to.has_value();
      if (is_share == is_attach)
        diagnostics.error(c.where, "a coupling is either 'share: [a, b]' or 'attach: a, to: b'");
      if (is_attach && !(spec.attach && spec.to))
        diagnostics.error(c.where, "an attach coupling needs both 'attach' and 'to'");
      for (const auto& s : spec.share) check_object_ref(scene, s, diagnostics);
      if (spec.attach) check_object_ref(scene, *spec.attach, diagnostics);
      if (spec.to) check_object_ref(scene, *spec.to, diagnostics);
      scene.couplings.push_back(spec);
    } catch (const std::logic_error&) {
    }
  }

  if (partial) return scene;
  const Value& solver = root.at("solver");
  SolverSpec& s = scene.solver;
  s.integrator = located_str(solver.at("integrator"));
  s.dt = located_num(solver.at("dt"));
  s.rayleigh_mass = solver.num("rayleigh_mass");
  s.rayleigh_stiffness = solver.num("rayleigh_stiffness");
  if (s.integrator.value == "variational" || s.integrator.value == "static")
    for (const char* key : {"rayleigh_mass", "rayleigh_stiffness"})
      if (solver.num(key) != 0)
        diagnostics.error(solver.at(key).where,
                          std::string(s.integrator.value == "variational"
                                          ? "solver: the variational integrator conserves energy and momentum"
                                          : "solver: a static solve has no inertia or velocities") +
                              " and takes no damping; remove '" + key + "' or use 'integrator: backward_euler'");
  s.load_steps = static_cast<int>(solver.integer_at("load_steps"));
  s.max_load_halvings = static_cast<int>(solver.integer_at("max_load_halvings"));
  s.threads = static_cast<int>(solver.integer_at("threads"));
  if (const Value* adaptive = solver.find("adaptive")) {
    s.adaptive = true;
    s.adaptive_tolerance = adaptive->num("tolerance");
    s.adaptive_min_dt = adaptive->num("min_dt");
    if (adaptive->has("max_dt")) s.adaptive_max_dt = adaptive->num("max_dt");
    if (s.integrator.value == "variational")
      diagnostics.error(adaptive->where, "solver.adaptive: adaptive time steps need 'integrator: backward_euler' or "
                                         "'static' (the variational integrator keeps a fixed dt)");
    if (s.adaptive_max_dt > 0 && s.adaptive_max_dt < s.adaptive_min_dt)
      diagnostics.error(adaptive->at("max_dt").where, "solver.adaptive: max_dt must be >= min_dt");
    if (s.dt.value < s.adaptive_min_dt)
      diagnostics.error(s.dt.where, "solver.dt (the first adaptive step) must be >= solver.adaptive.min_dt");
  }
  const Value& newton = solver.at("newton");
  s.newton_tolerance = newton.num("tolerance");
  s.newton_max_iterations = static_cast<int>(newton.integer_at("max_iterations"));
  s.newton_max_backtracks = static_cast<int>(newton.integer_at("max_backtracks"));
  s.newton_fixed_iterations = static_cast<int>(newton.integer_at("fixed_iterations"));
  const Value& linear = solver.at("linear");
  s.linear_method = located_str(linear.at("method"));
  s.linear_preconditioner = located_str(linear.at("preconditioner"));
  if (!linear.at("preconditioner").defaulted && s.linear_method.value != "pcg")
    diagnostics.error(linear.at("preconditioner").where,
                      "solver.linear: 'preconditioner' applies to method pcg (method " + s.linear_method.value +
                          (s.linear_method.value == "cg" ? " is plain CG" : " is a direct solve") +
                          "); remove 'preconditioner' or use 'method: pcg'");
  s.linear_tolerance = linear.num("tolerance");
  s.linear_max_iterations = static_cast<int>(linear.integer_at("max_iterations"));
  s.linear_fixed_iterations = linear.flag("fixed_iterations");

  const Value& run = root.at("run");
  scene.run.where = run.where;
  if (run.has("duration")) scene.run.duration = located_num(run.at("duration"));
  if (run.has("steps")) scene.run.steps = Located<int>{static_cast<int>(run.integer_at("steps")), run.at("steps").where};
  if (scene.run.duration && scene.run.steps) {
    diagnostics.error(scene.run.steps->where, "run: give either duration or steps, not both");
  } else if (scene.run.steps) {
    scene.run.step_count = scene.run.steps->value;
  } else if (scene.run.duration) {
    // Round to the nearest whole step when duration is a multiple of dt up to round-off.
    const double n = scene.run.duration->value / s.dt.value;
    const double steps = std::ceil(n - 1e-9 * std::max(1.0, n));
    if (!(steps <= kMaxSteps)) {
      diagnostics.error(scene.run.duration->where,
                        "run: duration " + format_si(scene.run.duration->value, dim::time) + " / dt " +
                            format_si(s.dt.value, dim::time) + " is " + format_si(n, dim::none) +
                            " steps, more than the " + std::to_string(kMaxSteps) +
                            " a run can take; check the units of duration and dt");
    } else {
      scene.run.step_count = std::max(1, static_cast<int>(steps));
    }
  } else if (s.integrator.value == "static") {
    scene.run.step_count = 1;
  } else {
    diagnostics.error(run.where, "run: a " + s.integrator.value +
                                     " scene needs a duration (e.g. 'duration: 1 s') or steps");
  }

  const Value& output = root.at("output");
  scene.output.every = static_cast<int>(output.integer_at("every"));
  scene.output.samples = output.flag("samples");
  scene.output.xdmf = output.flag("xdmf");
  scene.output.checkpoint_every = static_cast<int>(output.at("checkpoint").integer_at("every"));
  scene.output.checkpoint_interval = output.at("checkpoint").num("interval");
  if (output.has("file")) {
    scene.output.file = output.str("file");
  } else {
    scene.output.file = fs::path(file).stem().string() + ".h5";
  }
  return scene;
}

SceneSpec finish(SourceNode tree, const std::string& file, const std::vector<std::string>& overrides,
                 Diagnostics& diagnostics) {
  for (std::size_t k = 0; k < overrides.size(); ++k)
    apply_override(tree, overrides[k], static_cast<int>(k + 1), diagnostics);
  Value root = validate(tree, scene_registry(), diagnostics);
  if (!diagnostics.empty()) {
    extract(root, file, diagnostics, /*partial=*/true);
    throw SceneError(diagnostics);
  }
  SceneSpec scene = extract(root, file, diagnostics, /*partial=*/false);
  if (!diagnostics.empty()) throw SceneError(diagnostics);
  scene.resolved_yaml = to_yaml(root);
  return scene;
}

}  // namespace

SceneSpec parse_scene(const std::string& path, const std::vector<std::string>& overrides) {
  Diagnostics diagnostics;
  SourceNode tree = load_scene_tree(path, diagnostics);
  // A scene that cannot be read at all, or only in part (a refusal for size), has nothing more
  // to report.
  if (!diagnostics.empty() && (tree.is_null() || diagnostics.has(ExitCode::too_large))) throw SceneError(diagnostics);
  return finish(std::move(tree), path, overrides, diagnostics);
}

SceneSpec parse_scene_text(const std::string& text, const std::string& file, const std::vector<std::string>& overrides) {
  Diagnostics diagnostics;
  SourceNode tree = parse_yaml(text, file, diagnostics);
  if (!diagnostics.empty() && (tree.is_null() || diagnostics.has(ExitCode::too_large))) throw SceneError(diagnostics);
  if (tree.is_null() && diagnostics.empty()) tree.kind = SourceNode::Kind::map;
  if (!tree.is_null() && !tree.is_map()) {
    diagnostics.error(tree.where, "a scene must be a map of sections (materials, objects, ...), got " + tree.describe());
    throw SceneError(diagnostics);
  }
  if (tree.find("include") || tree.find("extends")) {
    diagnostics.error(tree.where, "include/extends need a scene file (use parse_scene)");
  }
  return finish(std::move(tree), file, overrides, diagnostics);
}

}  // namespace fascia::dsl
