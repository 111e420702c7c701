// The files a run reads and writes, and the rule that a run never destroys a file it did not
// create in this invocation: an existing output is refused unless --overwrite or --resume is
// given, and an output that is one of the run's inputs (scene, includes, meshes, surfaces) is
// always refused, as is a sidecar that would land on the trajectory itself.
#pragma once

#include "dsl/scene_spec.hpp"

#include <string>
#include <vector>

namespace fascia::app {

// Every file the scene reads: the scene file, each included scene that contributed a value, and
// every path-typed value of the registry (meshes, surfaces).
std::vector<std::string> run_inputs(const dsl::SceneSpec& spec);

enum class ExistingOutput { refuse, overwrite, resume };

// Why the outputs cannot be written ("" when they can). `outputs` are the trajectory first, then
// its sidecar(s); `existing` says what an existing trajectory may become. A sidecar left by an
// earlier run may be replaced only when its trajectory may be.
std::string output_refusal(const std::vector<std::string>& outputs, const std::vector<std::string>& inputs,
                           ExistingOutput existing);

}  // namespace fascia::app
