// libFuzzer target: the trajectory reader behind `fascia info` and `fascia run --resume`
// (io/trajectory, io/checkpoint): every summary `info` prints and the committed checkpoint, read
// from a damaged file. A file is summarised or refused with TrajectoryError; anything else is a
// finding.
#include "fuzz_input.hpp"
#include "io/checkpoint.hpp"
#include "io/trajectory.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace fascia;
  const std::string path = fuzz::scratch_file(data, size, ".h5");
  try {
    const TrajectoryReader reader(path);
    reader.times();
    reader.steps();
    reader.h5md_version();
    reader.creator_name();
    reader.creator_version();
    for (const char* p : {"scene", "scene_file", "command_line", "environment"}) reader.parameter(p);
    for (const ParticleGroupInfo& g : reader.particle_groups()) {
      for (const std::string& e : reader.particle_elements(g.name))
        if (reader.step_count() > 0) reader.particle_values(g.name, e, reader.step_count() - 1);
    }
    for (const std::string& o : reader.observable_names()) reader.observable(o);
  } catch (const TrajectoryError&) {
  } catch (const std::exception& e) {
    fuzz::finding(std::string("escaped exception from the trajectory reader: ") + e.what());
  }
  try {
    CheckpointIdentity identity;
    read_checkpoint(path, &identity);
  } catch (const TrajectoryError&) {
  } catch (const std::exception& e) {
    fuzz::finding(std::string("escaped exception from the checkpoint reader: ") + e.what());
  }
  return 0;
}
