#include "scene_report.hpp"

#include "output_check.hpp"

#include <iostream>
#include <sstream>

namespace fascia::app {

void add_scene_options(CLI::App& command, SceneRequest& request) {
  command.add_option("--set", request.overrides, "Override a scene value: path=value (e.g. materials.fascia.young=50kPa)")
      ->take_all()
      ->allow_extra_args(false);
  command
      .add_option("--max-memory", request.max_memory,
                  "Refuse scenes estimated to need more memory than this (e.g. 16G; default: the machine's memory "
                  "or the job's limit)")
      ->check(CLI::Validator([](std::string& text) { return dsl::parse_bytes(text) > 0 ? std::string() : "expected a size such as 512M or 16G"; },
                             "SIZE"));
}

std::string output_path(const SceneRequest& request, const dsl::SceneSpec& spec) {
  return request.output.empty() ? spec.output.file : request.output;
}

namespace {

void report(const dsl::Diagnostics& diagnostics, const std::string& path) {
  const auto items = diagnostics.sorted();
  for (const dsl::Diagnostic& d : items) std::cerr << d.str() << "\n";
  std::cerr << "fascia: " << items.size() << (items.size() == 1 ? " problem" : " problems") << " in " << path << "\n";
}

}  // namespace

std::unique_ptr<LoadedScene> load_scene(const SceneRequest& request, int& exit_code,
                                        const std::function<int(const dsl::SceneSpec&)>& before_build) {
  auto scene = std::make_unique<LoadedScene>();
  dsl::ResourceLimits limits;
  if (!request.max_memory.empty()) limits.max_memory = dsl::parse_bytes(request.max_memory);
  try {
    scene->spec = dsl::parse_scene(request.path, request.overrides);
    // The output before the discretisation: a path that cannot be written fails in a second.
    const std::string output = output_path(request, scene->spec);
    if (const std::string problem = output_path_problem(output); !problem.empty()) {
      dsl::Diagnostics diagnostics;
      const dsl::Value* file = scene->spec.resolved.find("output") ? scene->spec.resolved.find("output")->find("file")
                                                                   : nullptr;
      const dsl::Location where = request.output.empty() && file ? file->where : dsl::Location{"-o", 0, 0};
      diagnostics.error(where, "cannot write the output: " + problem, dsl::ExitCode::io_error);
      throw dsl::SceneError(diagnostics);
    }
    if (before_build) {
      if (const int code = before_build(scene->spec); code != 0) {
        exit_code = code;
        return nullptr;
      }
    }
    scene->built = dsl::build_scene(scene->spec, limits);
    dsl::Diagnostics diagnostics;
    check_output_space(output, scene->spec, scene->built, diagnostics);
    if (!diagnostics.empty()) throw dsl::SceneError(diagnostics);
  } catch (const dsl::SceneError& e) {
    report(e.diagnostics(), request.path);
    exit_code = static_cast<int>(e.exit_code());
    return nullptr;
  }
  exit_code = 0;
  return scene;
}

nlohmann::json couplings_json(const std::vector<dsl::CouplingReport>& couplings) {
  nlohmann::json out = nlohmann::json::array();
  for (const dsl::CouplingReport& c : couplings)
    out.push_back({{"kind", c.kind}, {"object", c.object}, {"other", c.other}, {"frames", c.frames},
                   {"within_m", c.within}, {"line", c.where.line}, {"column", c.where.column}});
  return out;
}

nlohmann::json stats_json(const dsl::DiscretisationStats& s) {
  return {{"frames", s.frames},
          {"samples", s.samples},
          {"dofs", s.dofs},
          {"fixed_frames", s.fixed_frames},
          {"neighbours_per_sample", {{"min", s.neighbours_min}, {"mean", s.neighbours_mean}, {"max", s.neighbours_max}}},
          {"volume_m3", s.volume},
          {"mass_kg", s.mass}};
}

std::string stats_text(const dsl::DiscretisationStats& s, const LoadedScene& scene) {
  std::ostringstream os;
  os.precision(6);
  os << "discretisation:\n";
  for (const dsl::BuiltObject& o : scene.built.objects)
    os << "  object " << o.name << ": " << o.discretisation << "; boundary " << o.surface.faces.size() / static_cast<std::size_t>(o.surface.nodes_per_face)
       << (o.surface.nodes_per_face == 3 ? " triangles, " : " quadrilaterals, ") << o.surface.vertex_frames.size()
       << " vertices\n";
  for (const dsl::BuiltObject& o : scene.built.objects)
    if (o.meshless) {
      os << "  meshless " << o.name << ":\n";
      std::istringstream lines(o.meshless->describe());
      for (std::string line; std::getline(lines, line);) os << "    " << line << "\n";
    }
  os << "  frames: " << s.frames << "\n"
     << "  samples: " << s.samples << "\n"
     << "  neighbours per sample: {min: " << s.neighbours_min << ", mean: " << s.neighbours_mean
     << ", max: " << s.neighbours_max << "}\n"
     << "  dofs: " << s.dofs << "\n"
     << "  fixed frames: " << s.fixed_frames << "\n"
     << "  volume: " << s.volume << " m^3\n"
     << "  mass: " << s.mass << " kg\n"
     << "  steps: " << scene.built.steps << "\n"
     << "  point forces: " << scene.built.loads.point_forces.size() << " frames\n"
     << "  material-point forces: " << scene.built.loads.material_point_forces.size() << "\n"
     << "  prescribed motions: " << scene.built.motions.size() << "\n";
  if (!scene.built.couplings.empty()) os << "couplings:\n";
  for (const dsl::CouplingReport& c : scene.built.couplings) {
    os << "  " << c.kind << " " << c.object << (c.kind == "share" ? " with " : " to ") << c.other << ": " << c.frames
       << " frames of " << c.object << (c.kind == "share" ? " merged into frames of " : " follow ") << c.other
       << " (within " << c.within << " m; " << c.where.line << ":" << c.where.column << ")\n";
  }
  return os.str();
}

}  // namespace fascia::app
