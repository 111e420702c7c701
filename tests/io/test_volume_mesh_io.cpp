#include "io/volume_mesh_io.hpp"

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

using namespace fascia;
namespace fs = std::filesystem;

TEST_CASE("legacy VTK volume meshes round-trip", "[io]") {
  const auto type = GENERATE(CellType::hexahedron, CellType::tetrahedron);
  const VolumeMesh mesh = type == CellType::hexahedron ? box_hex_mesh({0, 0, 0}, {1, 2, 3}, 2, 1, 3)
                                                      : box_tet_mesh({0, 0, 0}, {1, 2, 3}, 2, 1, 3);
  const fs::path path = fs::temp_directory_path() / "fascia_test_mesh.vtk";
  write_vtk_volume_mesh(path.string(), mesh);
  const VolumeMesh back = read_volume_mesh(path.string());
  CHECK(back.type == mesh.type);
  CHECK(back.cells == mesh.cells);
  CHECK(back.vertices == mesh.vertices);
  fs::remove(path);
}

TEST_CASE("Gmsh 2.2 ASCII tetrahedra are read, surface elements skipped", "[io]") {
  const fs::path path = fs::temp_directory_path() / "fascia_test_mesh.msh";
  std::ofstream(path) << "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n10 0 0 0\n11 1 0 0\n12 0 1 0\n13 0 0 1\n"
                         "$EndNodes\n$Elements\n2\n1 2 2 0 1 10 11 12\n2 4 2 0 1 10 11 12 13\n$EndElements\n";
  const VolumeMesh mesh = read_volume_mesh(path.string());
  CHECK(mesh.type == CellType::tetrahedron);
  CHECK(mesh.cells == std::vector<int>{0, 1, 2, 3});
  CHECK(mesh.vertex_count() == 4);
  fs::remove(path);
}

TEST_CASE("Gmsh files with a bad node section are refused naming the line", "[io]") {
  const fs::path path = fs::temp_directory_path() / "fascia_test_bad_nodes.msh";
  const std::string head = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n";
  const std::string nodes = "4\n10 0 0 0\n11 1 0 0\n12 0 1 0\n13 0 0 1\n$EndNodes\n";
  const std::string elements = "$Elements\n1\n1 4 2 0 1 10 11 12 13\n$EndElements\n";
  std::ofstream(path) << head << "-2\n" << elements;
  CHECK_THROWS_WITH(read_volume_mesh(path.string()), Catch::Contains("fascia_test_bad_nodes.msh:5: node count -2"));
  std::ofstream(path, std::ios::trunc) << head << nodes << "$Nodes\n" << nodes << elements;
  CHECK_THROWS_WITH(read_volume_mesh(path.string()), Catch::Contains(":11: a second $Nodes section"));
  std::ofstream(path, std::ios::trunc) << head << "2\n10 0 0 0\n10 1 0 0\n$EndNodes\n" << elements;
  CHECK_THROWS_WITH(read_volume_mesh(path.string()), Catch::Contains(":7: node id 10 appears twice"));
  std::ofstream(path, std::ios::trunc) << head << nodes << "$Elements\n-1\n$EndElements\n";
  CHECK_THROWS_WITH(read_volume_mesh(path.string()), Catch::Contains(":12: element count -1"));
  fs::remove(path);
}

TEST_CASE("broken meshes name the file and line", "[io]") {
  const fs::path path = fs::temp_directory_path() / "fascia_test_broken.vtk";
  std::ofstream(path) << "# vtk DataFile Version 3.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 2 double\n0 0 0\n1 q 0\n";
  CHECK_THROWS_WITH(read_volume_mesh(path.string()), Catch::Contains("fascia_test_broken.vtk:7: expected a coordinate"));
  CHECK_THROWS_AS(read_volume_mesh("/nonexistent/mesh.vtk"), std::ios_base::failure);
  CHECK_THROWS_AS(read_volume_mesh(path.string() + ".obj"), std::exception);
  fs::remove(path);
}
