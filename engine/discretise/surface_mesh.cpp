#include "discretise/surface_mesh.hpp"

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <unordered_map>

namespace fascia {
namespace {

constexpr double kPi = 3.14159265358979323846;

Vec3 vertex(const SurfaceMesh& m, int v) { return load3(&m.vertices[3 * v]); }

// Welds vertices with bit-identical coordinates; keeps first-seen order.
class Welder {
 public:
  explicit Welder(SurfaceMesh& mesh) : m_mesh(mesh) {}
  int add(const Vec3& p) {
    const auto key = std::make_tuple(p.x, p.y, p.z);
    const auto it = m_index.find(key);
    if (it != m_index.end()) return it->second;
    const int id = m_mesh.vertex_count();
    m_mesh.vertices.insert(m_mesh.vertices.end(), {p.x, p.y, p.z});
    m_index.emplace(key, id);
    return id;
  }
  void triangle(int a, int b, int c) {
    if (a == b || b == c || a == c) return;  // collapsed by welding
    m_mesh.triangles.insert(m_mesh.triangles.end(), {a, b, c});
  }

 private:
  SurfaceMesh& m_mesh;
  std::map<std::tuple<double, double, double>, int> m_index;
};

double orient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return dot(cross(b - a, c - a), d - a);
}

// Proper crossing of segment pq through the interior of triangle abc (touching excluded).
bool segment_crosses_triangle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  const double d1 = orient(a, b, c, p), d2 = orient(a, b, c, q);
  if (!((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0))) return false;
  const double e1 = orient(p, q, a, b), e2 = orient(p, q, b, c), e3 = orient(p, q, c, a);
  return (e1 > 0 && e2 > 0 && e3 > 0) || (e1 < 0 && e2 < 0 && e3 < 0);
}

}  // namespace

SurfaceMesh read_surface_mesh(const std::string& path, const SurfaceImport& import) {
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_PreTransformVertices);
  if (!scene || !scene->mRootNode)
    throw std::runtime_error("cannot read surface mesh '" + path + "': " + importer.GetErrorString());
  SurfaceMesh mesh;
  Welder welder(mesh);
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* am = scene->mMeshes[m];
    std::vector<int> ids(am->mNumVertices);
    for (unsigned v = 0; v < am->mNumVertices; ++v) {
      const aiVector3D& c = am->mVertices[v];
      if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.z))
        throw std::runtime_error("surface mesh '" + path + "': a vertex has a non-finite coordinate (nan or inf)");
      const Vec3 x = import.rotation * (import.scale * Vec3{c.x, c.y, c.z}) + import.translation;
      ids[v] = welder.add(x);
    }
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines
      welder.triangle(ids[face.mIndices[0]], ids[face.mIndices[1]], ids[face.mIndices[2]]);
    }
  }
  if (mesh.triangle_count() == 0) throw std::runtime_error("surface mesh '" + path + "' holds no triangle");
  return mesh;
}

std::string SurfaceDefects::describe() const {
  std::ostringstream out;
  const auto at = [&] {
    std::ostringstream p;
    p << " (first near " << first_defect.x << ", " << first_defect.y << ", " << first_defect.z << " m)";
    return p.str();
  };
  if (boundary_edges) out << boundary_edges << " boundary edges: the surface is open" << at() << "\n";
  if (non_manifold_edges) out << non_manifold_edges << " edges shared by more than two triangles" << at() << "\n";
  if (inconsistent_edges) out << inconsistent_edges << " edges with inconsistently oriented triangles" << at() << "\n";
  if (intersecting_pairs) out << intersecting_pairs << " pairs of self-intersecting triangles" << at() << "\n";
  if (degenerate_triangles) out << degenerate_triangles << " degenerate (zero-area) triangles\n";
  return out.str();
}

SurfaceDefects check_surface(const SurfaceMesh& mesh) {
  SurfaceDefects d;
  bool located = false;
  const auto locate = [&](const Vec3& p) {
    if (!located) d.first_defect = p;
    located = true;
  };
  const int t_count = mesh.triangle_count();
  // Directed edges (a, b): a closed, consistently oriented 2-manifold uses every undirected edge
  // exactly twice, once in each direction.
  std::vector<std::array<int, 3>> edges;  // (min, max, direction)
  edges.reserve(3 * t_count);
  for (int t = 0; t < t_count; ++t)
    for (int k = 0; k < 3; ++k) {
      const int a = mesh.triangles[3 * t + k], b = mesh.triangles[3 * t + (k + 1) % 3];
      edges.push_back({std::min(a, b), std::max(a, b), a < b ? 1 : 0});
    }
  std::sort(edges.begin(), edges.end());
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    int forward = 0;
    while (j < edges.size() && edges[j][0] == edges[i][0] && edges[j][1] == edges[i][1]) forward += edges[j++][2];
    const int uses = static_cast<int>(j - i);
    const Vec3 mid = 0.5 * (vertex(mesh, edges[i][0]) + vertex(mesh, edges[i][1]));
    if (uses == 1) ++d.boundary_edges, locate(mid);
    else if (uses > 2) ++d.non_manifold_edges, locate(mid);
    else if (forward != 1) ++d.inconsistent_edges, locate(mid);
    i = j;
  }

  Vec3 lo, hi;
  surface_bounds(mesh, lo, hi);
  const double diag = norm(hi - lo);
  double mean_edge = 0;
  for (int t = 0; t < t_count; ++t) {
    const Vec3 a = vertex(mesh, mesh.triangles[3 * t]), b = vertex(mesh, mesh.triangles[3 * t + 1]),
               c = vertex(mesh, mesh.triangles[3 * t + 2]);
    if (norm(cross(b - a, c - a)) <= 1e-14 * diag * diag) ++d.degenerate_triangles;
    mean_edge += (norm(b - a) + norm(c - b) + norm(a - c)) / 3;
  }
  mean_edge /= std::max(t_count, 1);

  // Broad phase: triangles binned by bounding box into cells of about two edge lengths.
  const double cell = std::max(2 * mean_edge, 1e-9 * diag);
  std::array<int, 3> dims;
  for (int k = 0; k < 3; ++k) dims[k] = 1 + static_cast<int>(((&hi.x)[k] - (&lo.x)[k]) / cell);
  std::unordered_map<long long, std::vector<int>> bins;
  const auto cell_of = [&](double x, int k) {
    return std::clamp(static_cast<int>((x - (&lo.x)[k]) / cell), 0, dims[k] - 1);
  };
  std::vector<std::array<int, 6>> boxes(t_count);
  for (int t = 0; t < t_count; ++t) {
    std::array<int, 6>& b = boxes[t];
    for (int k = 0; k < 3; ++k) {
      double mn = 1e300, mx = -1e300;
      for (int v = 0; v < 3; ++v) {
        const double x = mesh.vertices[3 * mesh.triangles[3 * t + v] + k];
        mn = std::min(mn, x), mx = std::max(mx, x);
      }
      b[k] = cell_of(mn, k), b[3 + k] = cell_of(mx, k);
    }
    for (int i = b[0]; i <= b[3]; ++i)
      for (int j = b[1]; j <= b[4]; ++j)
        for (int k = b[2]; k <= b[5]; ++k) bins[(static_cast<long long>(i) * dims[1] + j) * dims[2] + k].push_back(t);
  }
  for (const auto& [key, list] : bins) {
    const int ci = static_cast<int>(key / (static_cast<long long>(dims[1]) * dims[2]));
    const int cj = static_cast<int>((key / dims[2]) % dims[1]), ck = static_cast<int>(key % dims[2]);
    for (size_t x = 0; x < list.size(); ++x)
      for (size_t y = x + 1; y < list.size(); ++y) {
        const int s = list[x], t = list[y];
        // Test each pair once: in the lowest cell their bounding boxes share.
        if (std::max(boxes[s][0], boxes[t][0]) != ci || std::max(boxes[s][1], boxes[t][1]) != cj ||
            std::max(boxes[s][2], boxes[t][2]) != ck)
          continue;
        const int* A = &mesh.triangles[3 * s];
        const int* B = &mesh.triangles[3 * t];
        bool shared = false;
        for (int u = 0; u < 3; ++u)
          for (int v = 0; v < 3; ++v) shared = shared || A[u] == B[v];
        if (shared) continue;
        std::array<Vec3, 3> a, b;
        for (int u = 0; u < 3; ++u) a[u] = vertex(mesh, A[u]), b[u] = vertex(mesh, B[u]);
        bool crosses = false;
        for (int u = 0; u < 3 && !crosses; ++u)
          crosses = segment_crosses_triangle(a[u], a[(u + 1) % 3], b[0], b[1], b[2]) ||
                    segment_crosses_triangle(b[u], b[(u + 1) % 3], a[0], a[1], a[2]);
        if (crosses) ++d.intersecting_pairs, locate((1.0 / 3) * (a[0] + a[1] + a[2]));
      }
  }
  return d;
}

double surface_volume(const SurfaceMesh& mesh) {
  double v = 0;
  for (int t = 0; t < mesh.triangle_count(); ++t)
    v += dot(vertex(mesh, mesh.triangles[3 * t]),
             cross(vertex(mesh, mesh.triangles[3 * t + 1]), vertex(mesh, mesh.triangles[3 * t + 2])));
  return v / 6;
}

double surface_area(const SurfaceMesh& mesh) {
  double a = 0;
  for (int t = 0; t < mesh.triangle_count(); ++t) {
    const Vec3 p = vertex(mesh, mesh.triangles[3 * t]);
    a += 0.5 * norm(cross(vertex(mesh, mesh.triangles[3 * t + 1]) - p, vertex(mesh, mesh.triangles[3 * t + 2]) - p));
  }
  return a;
}

void surface_bounds(const SurfaceMesh& mesh, Vec3& lo, Vec3& hi) {
  lo = Vec3{1e300, 1e300, 1e300};
  hi = -lo;
  for (int v = 0; v < mesh.vertex_count(); ++v) {
    const Vec3 p = vertex(mesh, v);
    lo = Vec3{std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = Vec3{std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
}

SurfaceMesh box_surface(const Vec3& lo, const Vec3& hi, int nx, int ny, int nz) {
  SurfaceMesh mesh;
  Welder welder(mesh);
  const std::array<int, 3> n{nx, ny, nz};
  std::array<std::vector<double>, 3> coords;
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i <= n[k]; ++i)
      coords[k].push_back(i == n[k] ? (&hi.x)[k] : (&lo.x)[k] + ((&hi.x)[k] - (&lo.x)[k]) * i / n[k]);
  // Face with normal along axis a (side 0 = low, 1 = high), spanned by axes b and c.
  for (int a = 0; a < 3; ++a)
    for (int side = 0; side < 2; ++side) {
      const int b = (a + 1) % 3, c = (a + 2) % 3;
      const auto point = [&](int i, int j) {
        double x[3];
        x[a] = side ? (&hi.x)[a] : (&lo.x)[a];
        x[b] = coords[b][i];
        x[c] = coords[c][j];
        return welder.add(Vec3{x[0], x[1], x[2]});
      };
      for (int i = 0; i < n[b]; ++i)
        for (int j = 0; j < n[c]; ++j) {
          const int p00 = point(i, j), p10 = point(i + 1, j), p11 = point(i + 1, j + 1), p01 = point(i, j + 1);
          // (b, c, a) is right-handed: counter-clockwise in (b, c) faces +a.
          if (side) welder.triangle(p00, p10, p11), welder.triangle(p00, p11, p01);
          else welder.triangle(p00, p11, p10), welder.triangle(p00, p01, p11);
        }
    }
  return mesh;
}

SurfaceMesh sphere_surface(const Vec3& centre, double radius, int subdivisions) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<Vec3> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                         {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (Vec3& p : v) p = (1 / norm(p)) * p;
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<int, int>, int> mid;
    const auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      const auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      const Vec3 m = v[a] + v[b];
      v.push_back((1 / norm(m)) * m);
      return mid[key] = static_cast<int>(v.size()) - 1;
    };
    std::vector<std::array<int, 3>> g;
    for (const auto& tri : f) {
      const int ab = midpoint(tri[0], tri[1]), bc = midpoint(tri[1], tri[2]), ca = midpoint(tri[2], tri[0]);
      g.push_back({tri[0], ab, ca}), g.push_back({tri[1], bc, ab}), g.push_back({tri[2], ca, bc});
      g.push_back({ab, bc, ca});
    }
    f = std::move(g);
  }
  SurfaceMesh mesh;
  for (const Vec3& p : v) {
    const Vec3 x = centre + radius * p;
    mesh.vertices.insert(mesh.vertices.end(), {x.x, x.y, x.z});
  }
  for (const auto& tri : f) mesh.triangles.insert(mesh.triangles.end(), {tri[0], tri[1], tri[2]});
  return mesh;
}

SurfaceMesh torus_surface(const Vec3& centre, double major_radius, double minor_radius, int major_segments,
                          int minor_segments) {
  SurfaceMesh mesh;
  for (int i = 0; i < major_segments; ++i)
    for (int j = 0; j < minor_segments; ++j) {
      const double u = 2 * kPi * i / major_segments, v = 2 * kPi * j / minor_segments;
      const double rho = major_radius + minor_radius * std::cos(v);
      const Vec3 x = centre + Vec3{rho * std::cos(u), rho * std::sin(u), minor_radius * std::sin(v)};
      mesh.vertices.insert(mesh.vertices.end(), {x.x, x.y, x.z});
    }
  const auto id = [&](int i, int j) { return (i % major_segments) * minor_segments + j % minor_segments; };
  for (int i = 0; i < major_segments; ++i)
    for (int j = 0; j < minor_segments; ++j) {
      // d/du points along the tube, d/dv around it; (d/du x d/dv) points outwards.
      const int a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      mesh.triangles.insert(mesh.triangles.end(), {a, b, c, a, c, d});
    }
  return mesh;
}

}  // namespace fascia
