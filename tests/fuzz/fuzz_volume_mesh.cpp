// libFuzzer target: the volume mesh readers (legacy VTK, Gmsh; io/volume_mesh_io.hpp), the format
// chosen by FASCIA_FUZZ_EXTENSION. A file is read, with every cell index in range, or refused
// with MeshFormatError; anything else is a finding.
#include "fuzz_input.hpp"
#include "io/volume_mesh_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = fascia::fuzz::scratch_file(data, size, FASCIA_FUZZ_EXTENSION);
  try {
    const fascia::VolumeMesh mesh = fascia::read_volume_mesh(path);
    for (int v : mesh.cells)
      if (v < 0 || v >= mesh.vertex_count()) fascia::fuzz::finding("cell index " + std::to_string(v) + " out of range");
  } catch (const fascia::MeshFormatError&) {
  } catch (const std::exception& e) {
    fascia::fuzz::finding(std::string("escaped exception: ") + e.what());
  }
  return 0;
}
