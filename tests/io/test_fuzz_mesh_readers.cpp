// Mutation fuzz of the mesh readers (legacy VTK and Gmsh volume meshes; OBJ and STL surfaces
// through Assimp): a mutated file is read or refused with the reader's own errors
// (MeshFormatError, std::runtime_error, std::ios_base::failure, which the scene builder reports
// as exit 65 or 66); std::bad_alloc, std::logic_error (std::length_error) and other exceptions
// fail, as would a crash or a hang. FASCIA_FUZZ_RUNS and FASCIA_FUZZ_SEED as in
// tests/dsl/test_fuzz_scenes.cpp.
#include "discretise/surface_mesh.hpp"
#include "io/volume_mesh_io.hpp"
#include "support/mutator.hpp"

#include <catch2/catch.hpp>

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <ios>
#include <sstream>

namespace fs = std::filesystem;
using namespace fascia;
using namespace fascia::test;

TEST_CASE("mutated mesh files are read or refused with the readers' errors", "[io][fuzz]") {
  struct Seed {
    std::string extension, text;
  };
  std::vector<Seed> corpus;
  for (const char* dir : {"scenes/meshes", "tests/dsl/bad_scenes/data"}) {
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(fs::path(FASCIA_SOURCE_DIR) / dir)) files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    for (const fs::path& f : files) {
      const std::string ext = f.extension().string();
      if (ext != ".vtk" && ext != ".obj" && ext != ".stl") continue;
      std::ifstream in(f, std::ios::binary);
      std::ostringstream text;
      text << in.rdbuf();
      corpus.push_back({ext, text.str()});
    }
  }
  corpus.push_back({".msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n10 0 0 0\n11 1 0 0\n12 0 1 0\n13 0 0 1\n"
                            "$EndNodes\n$Elements\n2\n1 2 2 0 1 10 11 12\n2 4 2 0 1 10 11 12 13\n$EndElements\n"});
  REQUIRE(corpus.size() >= 8);

  const fs::path dir = fs::temp_directory_path() / ("fascia_fuzz_meshes_" + std::to_string(getpid()));
  fs::create_directories(dir);
  // 300 files read in about a second; the shipped meshes are a few kilobytes each.
  const std::uint64_t runs = env_or("FASCIA_FUZZ_RUNS", 300);
  Draw draw(env_or("FASCIA_FUZZ_SEED", 20261124));
  int read = 0, refused = 0;
  for (std::uint64_t run = 0; run < runs; ++run) {
    const Seed& seed = draw.pick(corpus);
    const std::string text = mutate(seed.text, draw);
    const fs::path file = dir / ("mesh" + seed.extension);
    std::ofstream(file, std::ios::binary | std::ios::trunc) << text;
    INFO("run " << run << ", a mutated " << seed.extension << " file:\n" << text.substr(0, 1500));
    try {
      if (seed.extension == ".vtk" || seed.extension == ".msh") {
        const VolumeMesh mesh = read_volume_mesh(file.string());
        for (int v : mesh.cells) REQUIRE((v >= 0 && v < mesh.vertex_count()));
      } else {
        const SurfaceMesh mesh = read_surface_mesh(file.string());
        for (int v : mesh.triangles) REQUIRE((v >= 0 && v < mesh.vertex_count()));
        for (double x : mesh.vertices) REQUIRE(std::isfinite(x));
      }
      ++read;
    } catch (const MeshFormatError&) {
      ++refused;
    } catch (const std::ios_base::failure&) {
      ++refused;
    } catch (const std::logic_error& e) {
      FAIL("logic error: " << e.what());
    } catch (const std::runtime_error&) {
      ++refused;  // Assimp's and the surface checks' errors
    } catch (const std::exception& e) {
      FAIL("escaped exception: " << e.what());
    }
  }
  fs::remove_all(dir);
  CHECK(read > 0);
  CHECK(refused > 0);
}
