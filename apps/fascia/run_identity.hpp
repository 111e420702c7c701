// What a checkpoint must match to be resumed (io/checkpoint.hpp): the resolved scene and the
// build of the program. Bitwise-identical continuation also needs the same backend, precision
// and thread count; those are recorded in /parameters/environment and only warned about.
#pragma once

#include "dsl/scene_spec.hpp"

#include <string>

namespace fascia::app {

// "fascia 0.1.0, executable fnv1a64w:0123456789abcdef, voxel module fnv1a64w:...": the version and
// hashes of the running executable's bytes (/proc/self/exe) and of the voxelisation module it
// loads (discretise/voxel_module.hpp; left out where there is none), so that any rebuild with
// other code is another build.
const std::string& build_identity();

// The resolved scene (YAML, SI units, defaults) without the keys that do not change the
// computed states: output.file (the run's file is where the checkpoint lives) and
// output.checkpoint (the cadence of checkpoints).
std::string scene_identity(const dsl::SceneSpec& spec);

// "line 12: 'young: 40000 Pa' here, 'young: 50000 Pa' in the checkpoint" for the first line
// where two texts differ ("" when equal).
std::string first_difference(const std::string& here, const std::string& stored);

}  // namespace fascia::app
