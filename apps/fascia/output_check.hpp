// The output path, checked before the scene is discretised (and by `fascia check`): a directory,
// a missing or read-only folder and, once the model's size is known, too little free space for
// the preallocated rows are reported before any work is done, with the operating system's reason.
#pragma once

#include "dsl/build_scene.hpp"

#include <string>

namespace fascia::app {

// "" when `path` can be created or replaced, else why not ("'out/run.h5': No such file or directory").
std::string output_path_problem(const std::string& path);

// Rows an output file preallocates: the initial state, every `every`-th of `steps` steps, and
// one written on a signal (as `fascia run` creates them).
long long output_rows(long long steps, int every);

// Refuses (dsl::ExitCode::too_large, at the scene's step count) an output whose preallocated
// rows would not fit on its file system, or that would need more rows than a file can index.
void check_output_space(const std::string& path, const dsl::SceneSpec& spec, const dsl::BuiltScene& built,
                        dsl::Diagnostics& diagnostics);

}  // namespace fascia::app
