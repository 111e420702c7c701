// Surface mesh input: every exchange format clinicians' tools export, unit scaling, transforms,
// and clear reports of open, flipped and self-intersecting input.
#include "discretise/meshless.hpp"
#include "discretise/surface_mesh.hpp"

#include <catch2/catch.hpp>

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>

using namespace fascia;

namespace {

const SurfaceMesh& unit_box() {
  static const SurfaceMesh box = box_surface({0, 0, 0}, {30, 20, 10});  // millimetres, 12 triangles
  return box;
}

std::string temp_path(const std::string& name) { return std::string(P_tmpdir) + "/fascia_test_" + name; }

Vec3 corner(const SurfaceMesh& m, int t, int k) { return load3(&m.vertices[3 * m.triangles[3 * t + k]]); }

void write_file(const std::string& path, const std::string& format, const SurfaceMesh& m) {
  std::ofstream out(path, std::ios::binary);
  if (format == "stl") {
    out << "solid box\n";
    for (int t = 0; t < m.triangle_count(); ++t) {
      out << " facet normal 0 0 0\n  outer loop\n";
      for (int k = 0; k < 3; ++k) {
        const Vec3 p = corner(m, t, k);
        out << "   vertex " << p.x << " " << p.y << " " << p.z << "\n";
      }
      out << "  endloop\n endfacet\n";
    }
    out << "endsolid box\n";
  } else if (format == "binary.stl") {
    const std::string header(80, ' ');
    out.write(header.data(), 80);
    const std::uint32_t n = m.triangle_count();
    out.write(reinterpret_cast<const char*>(&n), 4);
    for (int t = 0; t < m.triangle_count(); ++t) {
      float f[12] = {0, 0, 0};
      for (int k = 0; k < 3; ++k) {
        const Vec3 p = corner(m, t, k);
        f[3 + 3 * k] = float(p.x), f[4 + 3 * k] = float(p.y), f[5 + 3 * k] = float(p.z);
      }
      out.write(reinterpret_cast<const char*>(f), sizeof f);
      const std::uint16_t attr = 0;
      out.write(reinterpret_cast<const char*>(&attr), 2);
    }
  } else if (format == "obj") {
    for (int v = 0; v < m.vertex_count(); ++v)
      out << "v " << m.vertices[3 * v] << " " << m.vertices[3 * v + 1] << " " << m.vertices[3 * v + 2] << "\n";
    for (int t = 0; t < m.triangle_count(); ++t)
      out << "f " << m.triangles[3 * t] + 1 << " " << m.triangles[3 * t + 1] + 1 << " " << m.triangles[3 * t + 2] + 1 << "\n";
  } else if (format == "ply") {
    out << "ply\nformat ascii 1.0\nelement vertex " << m.vertex_count()
        << "\nproperty float x\nproperty float y\nproperty float z\nelement face " << m.triangle_count()
        << "\nproperty list uchar int vertex_indices\nend_header\n";
    for (int v = 0; v < m.vertex_count(); ++v)
      out << m.vertices[3 * v] << " " << m.vertices[3 * v + 1] << " " << m.vertices[3 * v + 2] << "\n";
    for (int t = 0; t < m.triangle_count(); ++t)
      out << "3 " << m.triangles[3 * t] << " " << m.triangles[3 * t + 1] << " " << m.triangles[3 * t + 2] << "\n";
  } else if (format == "off") {
    out << "OFF\n" << m.vertex_count() << " " << m.triangle_count() << " 0\n";
    for (int v = 0; v < m.vertex_count(); ++v)
      out << m.vertices[3 * v] << " " << m.vertices[3 * v + 1] << " " << m.vertices[3 * v + 2] << "\n";
    for (int t = 0; t < m.triangle_count(); ++t)
      out << "3 " << m.triangles[3 * t] << " " << m.triangles[3 * t + 1] << " " << m.triangles[3 * t + 2] << "\n";
  }
}

}  // namespace

TEST_CASE("generated surfaces are closed, outward and have the expected volume", "[discretise][surface]") {
  REQUIRE(check_surface(unit_box()).ok());
  REQUIRE(surface_volume(unit_box()) == Approx(6000).epsilon(1e-14));
  const SurfaceMesh sub = box_surface({0, 0, 0}, {1, 2, 3}, 3, 4, 5);
  REQUIRE(check_surface(sub).ok());
  REQUIRE(surface_volume(sub) == Approx(6).epsilon(1e-13));
  REQUIRE(surface_area(sub) == Approx(22).epsilon(1e-13));
  REQUIRE(check_surface(sphere_surface({0, 0, 0}, 1, 3)).ok());
  REQUIRE(surface_volume(sphere_surface({0, 0, 0}, 1, 3)) > 0);
  REQUIRE(check_surface(torus_surface({0, 0, 0}, 1, 0.3, 48, 16)).ok());
  REQUIRE(surface_volume(torus_surface({0, 0, 0}, 1, 0.3, 48, 16)) > 0);
}

TEST_CASE("surface meshes are read from STL, binary STL, OBJ, PLY and OFF with scale and transform",
          "[discretise][surface]") {
  const std::string format = GENERATE(std::string("stl"), std::string("binary.stl"), std::string("obj"),
                                      std::string("ply"), std::string("off"));
  const std::string path = temp_path("box." + format);
  write_file(path, format, unit_box());
  SurfaceImport import;
  import.scale = 0.001;                                   // millimetres to metres
  import.rotation = Mat3{{{0, -1, 0}, {1, 0, 0}, {0, 0, 1}}};  // 90 degrees about z
  import.translation = Vec3{1, 2, 3};
  const SurfaceMesh mesh = read_surface_mesh(path, import);
  std::remove(path.c_str());
  INFO(format);
  REQUIRE(mesh.vertex_count() == 8);  // STL's per-facet vertices are welded
  REQUIRE(mesh.triangle_count() == 12);
  REQUIRE(check_surface(mesh).ok());
  REQUIRE(std::abs(surface_volume(mesh)) == Approx(6e-6).epsilon(1e-6));  // float files: 1e-7 relative
  Vec3 lo, hi;
  surface_bounds(mesh, lo, hi);
  // x' = -y * 0.001 + 1 in [0.98, 1], y' = x * 0.001 + 2 in [2, 2.03], z' in [3, 3.01].
  REQUIRE(lo.x == Approx(0.98).epsilon(1e-6));
  REQUIRE(hi.x == Approx(1.0).epsilon(1e-6));
  REQUIRE(hi.y == Approx(2.03).epsilon(1e-6));
  REQUIRE(hi.z == Approx(3.01).epsilon(1e-6));
}

TEST_CASE("a missing or unreadable file is reported with its name", "[discretise][surface]") {
  REQUIRE_THROWS_WITH(read_surface_mesh("/nonexistent/organ.stl"), Catch::Contains("/nonexistent/organ.stl"));
}

TEST_CASE("open, flipped and self-intersecting surfaces are reported", "[discretise][surface]") {
  SECTION("open") {
    SurfaceMesh open = unit_box();
    open.triangles.resize(open.triangles.size() - 3);
    const SurfaceDefects d = check_surface(open);
    REQUIRE(d.boundary_edges == 3);
    REQUIRE_FALSE(d.ok());
    REQUIRE_THAT(d.describe(), Catch::Contains("open"));
    MeshlessOptions options;
    options.frame_spacing = 4, options.sample_spacing = 2;
    REQUIRE_THROWS_WITH(build_meshless_model(open, make_material(MaterialLaw::stvk, 1e4, 0.3, 1000), options),
                        Catch::Contains("open"));
  }
  SECTION("flipped") {
    SurfaceMesh flipped = unit_box();
    std::swap(flipped.triangles[0], flipped.triangles[1]);
    const SurfaceDefects d = check_surface(flipped);
    REQUIRE(d.inconsistent_edges == 3);
    REQUIRE(d.closed());
    REQUIRE_FALSE(d.ok());
  }
  SECTION("self-intersecting") {
    SurfaceMesh two = box_surface({0, 0, 0}, {1, 1, 1});
    const SurfaceMesh other = box_surface({0.5, 0.3, 0.2}, {1.5, 0.8, 0.7});
    const int offset = two.vertex_count();
    two.vertices.insert(two.vertices.end(), other.vertices.begin(), other.vertices.end());
    for (int v : other.triangles) two.triangles.push_back(v + offset);
    const SurfaceDefects d = check_surface(two);
    REQUIRE(d.closed());
    REQUIRE(d.intersecting_pairs > 0);
    REQUIRE_THAT(d.describe(), Catch::Contains("self-intersecting"));
    // Two disjoint boxes are fine.
    SurfaceMesh apart = box_surface({0, 0, 0}, {1, 1, 1});
    const SurfaceMesh far = box_surface({2, 0, 0}, {3, 1, 1});
    for (double x : far.vertices) apart.vertices.push_back(x);
    for (int v : far.triangles) apart.triangles.push_back(v + 8);
    REQUIRE(check_surface(apart).ok());
  }
}
