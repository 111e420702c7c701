// A parameter sweep: a base scene and the values to vary over any scene path, expanded into
// numbered runs (docs/hpc.md). The sweep file:
//
//   scene: ../tool_pull.yaml           base scene, relative to the sweep file
//   name: pull                         run names pull-000, pull-001, ... (default: the file's stem)
//   folder: runs                       where the runs' files go, relative to the working directory
//                                      (default: the name)
//   set: {run.duration: 0.3 s}         overrides of every run
//   cross:                             every combination of these (the first varies slowest)
//     materials.fascia.young: [20 kPa, 40 kPa, 80 kPa]          a list of values
//     solver.dt: {from: 5 ms, to: 20 ms, count: 4}              a range (scale: linear | log)
//   zip:                               groups of equally long lists varied together, crossed
//     - {loads.0.gravity: ["0 0 -9.81", "0 0 -5"], run.duration: [1 s, 2 s]}   with the rest
//   slurm: {partition: debug, time: "1:00:00", cpus_per_task: 4, gpus_per_task: 1,
//           signal: 2 min, extra: ["--qos=short"]}
//
// A value is anything `fascia run --set path=value` takes; a range's ends are quantities of one
// dimension and its values are written in SI units.
#pragma once

#include "dsl/diagnostics.hpp"

#include <string>
#include <utility>
#include <vector>

namespace fascia::app {

struct SweepRun {
  int task = 0;
  std::string name;    // pull-003
  std::string output;  // folder/pull-003.h5
  std::vector<std::pair<std::string, std::string>> parameters;  // the varied (path, value), in order
  std::vector<std::string> overrides;                           // --set texts: `set` then parameters
};

struct SlurmSettings {
  std::string partition, time = "1:00:00", account;
  int cpus_per_task = 1, gpus_per_task = 0;
  double signal_seconds = 120;  // the stop signal this long before the time limit
  std::vector<std::string> extra;
};

struct Sweep {
  std::string file;        // the sweep file as given
  std::string scene;       // resolved path of the base scene
  std::string name, folder;
  std::vector<std::string> parameter_names;  // varied paths, in column order
  std::vector<SweepRun> runs;
  SlurmSettings slurm;
};

// Reads and expands a sweep file. Throws dsl::SceneError with every problem found (file:line:col).
Sweep read_sweep(const std::string& path);

}  // namespace fascia::app
