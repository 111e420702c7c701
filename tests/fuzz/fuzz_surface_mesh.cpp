// libFuzzer target: the surface mesh reader (Assimp: OBJ, STL, PLY, OFF; discretise/surface_mesh),
// the format chosen by FASCIA_FUZZ_EXTENSION. A file is read, with finite vertices and triangle
// indices in range, or refused with std::runtime_error naming the file; anything else is a finding.
#include "discretise/surface_mesh.hpp"
#include "fuzz_input.hpp"

#include <cmath>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = fascia::fuzz::scratch_file(data, size, FASCIA_FUZZ_EXTENSION);
  try {
    const fascia::SurfaceMesh mesh = fascia::read_surface_mesh(path);
    for (int v : mesh.triangles)
      if (v < 0 || v >= mesh.vertex_count()) fascia::fuzz::finding("triangle index " + std::to_string(v) + " out of range");
    for (double x : mesh.vertices)
      if (!std::isfinite(x)) fascia::fuzz::finding("a non-finite vertex coordinate");
  } catch (const std::logic_error& e) {
    fascia::fuzz::finding(std::string("logic error: ") + e.what());
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).find(path) == std::string::npos)
      fascia::fuzz::finding(std::string("a refusal that does not name the file: ") + e.what());
  } catch (const std::exception& e) {
    fascia::fuzz::finding(std::string("escaped exception: ") + e.what());
  }
  return 0;
}
