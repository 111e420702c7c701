// fascia check SCENE: validate a scene, print it resolved (defaults, SI units) and the
// discretisation figures and what every coupling did (frames merged or attached), without solving.
#include "commands.hpp"
#include "scene_report.hpp"

#include <iostream>
#include <memory>

namespace fascia::app {

namespace {

struct CheckOptions {
  SceneRequest request;
  bool json = false;
};

int check(const CheckOptions& options) {
  int code = 0;
  std::unique_ptr<LoadedScene> scene = load_scene(options.request, code);
  if (!scene) return code;
  if (options.json) {
    nlohmann::json out = {{"scene", options.request.path}, {"ok", true}, {"discretisation", stats_json(scene->built.stats)},
                          {"steps", scene->built.steps}, {"couplings", couplings_json(scene->built.couplings)},
                          {"resolved_scene", scene->spec.resolved_yaml}};
    for (const dsl::BuiltObject& o : scene->built.objects)
      if (o.meshless) {
        const MeshlessStatistics& m = *o.meshless;
        out["meshless"][o.name] = {
            {"frames", m.frames},
            {"added_frames", m.added_frames},
            {"samples", m.samples},
            {"neighbours_per_sample", {{"min", m.neighbours_min}, {"mean", m.neighbours_mean}, {"max", m.neighbours_max}}},
            {"min_spread", m.min_spread},
            {"voxel_size_m", m.voxel_size},
            {"frame_voxel_size_m", m.frame_voxel_size},
            {"surface_volume_m3", m.surface_volume},
            {"volume_error", m.volume_error},
            {"sample_volume_m3", m.sample_volume},
            {"seconds",
             {{"voxelise", m.seconds_voxelise},
              {"frames", m.seconds_frames},
              {"samples", m.seconds_samples},
              {"volumes", m.seconds_volumes},
              {"shape_functions", m.seconds_shape},
              {"consistent_integration", m.seconds_integration},
              {"total", m.seconds_total}}}};
      }
    std::cout << out.dump(2) << "\n";
    return kOk;
  }
  std::cout << "# " << options.request.path << ": resolved scene (defaults filled in, SI units)\n"
            << scene->spec.resolved_yaml << "---\n"
            << stats_text(scene->built.stats, *scene);
  std::cerr << "fascia: " << options.request.path << " is valid\n";
  return kOk;
}

}  // namespace

void register_check(CLI::App& app, Action& action) {
  auto options = std::make_shared<CheckOptions>();
  CLI::App* cmd = app.add_subcommand("check", "Validate a scene and print it resolved, with discretisation figures");
  cmd->add_option("scene", options->request.path, "Scene file (YAML)")->required();
  add_scene_options(*cmd, options->request);
  cmd->add_flag("--json", options->json, "Print a JSON summary on stdout");
  cmd->callback([&action, options] { action = [options] { return check(*options); }; });
}

}  // namespace fascia::app
