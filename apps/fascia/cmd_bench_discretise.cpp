#include "cmd_bench_discretise.hpp"

#include "bench/discretise_bench.hpp"
#include "bench/label_image_bench.hpp"

#include <unistd.h>

#include <filesystem>

#include <iostream>
#include <memory>

namespace fascia::app {

void add_bench_discretise(CLI::App& bench, Action& action) {
  auto options = std::make_shared<DiscretiseBenchOptions>();
  auto json = std::make_shared<bool>(false);
  auto phantom_size = std::make_shared<int>(0);
  auto image = std::make_shared<std::string>();
  CLI::App* cmd = bench.add_subcommand(
      "discretise",
      "Time the meshless discretisation (voxelise, frames, samples, volumes, shape functions, consistent integration)");
  cmd->add_option("--samples", options->sample_counts, "Target sample counts (about 10 per frame)")
      ->capture_default_str();
  cmd->add_option("--neighbours", options->neighbours,
                  "Each frame's support is 1.6 times the distance to its k-th nearest frame: k")
      ->capture_default_str();
  cmd->add_option("--seed", options->seed, "Poisson-disk seed")->capture_default_str();
  cmd->add_flag("--json", *json, "One JSON object per line on stdout");
  auto* phantom_option =
      cmd->add_option("--label-image", *phantom_size,
                      "Instead: write a synthetic N^3 label image (4 labels, oblique 0.7 x 0.8 x 1.25 mm voxels) to a "
                      "temporary .nii.gz, then time reading it and voxelising each label")
          ->check(CLI::Range(16, 1024));
  cmd->add_option("--image", *image, "Instead: time reading this label image and voxelising each label")
      ->check(CLI::ExistingFile)
      ->excludes(phantom_option);
  cmd->callback([options, json, phantom_size, image, &action] {
    action = [options, json, phantom_size, image] {
      if (*phantom_size > 0) {
        const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                           ("fascia_label_phantom_" + std::to_string(::getpid()) + ".nii.gz");
        write_label_image_phantom(path.string(), *phantom_size);
        LabelImageBench result;
        try {
          result = bench_label_image(path.string());
        } catch (...) {
          std::filesystem::remove(path);
          throw;
        }
        std::filesystem::remove(path);
        write_label_image_bench(std::cout, result, *json);
        return kOk;
      }
      if (!image->empty()) {
        write_label_image_bench(std::cout, bench_label_image(*image), *json);
        return kOk;
      }
      for (long n : options->sample_counts) write_bench_row(std::cout, bench_discretise_once(n, *options), *json);
      return kOk;
    };
  });
}

}  // namespace fascia::app
