#include "io/volume_mesh_io.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unordered_map>
#include <vector>

namespace fascia {

namespace {

// Line-oriented tokenizer that knows the current line for messages.
class Reader {
 public:
  // @param bytes the file's size, which bounds every count it declares (0: unknown).
  Reader(std::istream& in, std::string path, std::uintmax_t bytes) : m_in(in), m_path(std::move(path)), m_bytes(bytes) {}

  // Refuses a declared count of items of at least `min_bytes` characters each that the file is
  // too short to hold, before anything is allocated for them.
  void check_count(long long count, int min_bytes, const std::string& what) const {
    if (m_bytes > 0 && static_cast<double>(count) * min_bytes > static_cast<double>(m_bytes))
      fail(what + " " + std::to_string(count) + " cannot fit in the file's " + std::to_string(m_bytes) +
           " bytes (truncated or corrupt)");
  }

  bool next_line(std::string& line) {
    while (std::getline(m_in, line)) {
      ++m_line;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (line.find_first_not_of(" \t") != std::string::npos) return true;
    }
    return false;
  }

  // Next whitespace-separated token, across lines.
  bool token(std::string& out) {
    while (!(m_tokens >> out)) {
      std::string line;
      if (!next_line(line)) return false;
      m_tokens.clear();
      m_tokens.str(line);
    }
    return true;
  }

  template <class T>
  T number(const char* what) {
    std::string t;
    if (!token(t)) fail(std::string("unexpected end of file, expected ") + what);
    std::istringstream ss(t);
    T v{};
    if (!(ss >> v) || !ss.eof()) fail(std::string("expected ") + what + ", got '" + t + "'");
    return v;
  }

  [[noreturn]] void fail(const std::string& message) const {
    throw MeshFormatError(m_path + ":" + std::to_string(m_line) + ": " + message);
  }

  void reset_tokens() {
    m_tokens.clear();
    m_tokens.str("");
  }

 private:
  std::istream& m_in;
  std::string m_path;
  int m_line = 0;
  std::istringstream m_tokens;
  std::uintmax_t m_bytes = 0;
};

VolumeMesh read_vtk(std::istream& in, const std::string& path, std::uintmax_t bytes) {
  Reader r(in, path, bytes);
  std::string line;
  if (!r.next_line(line) || line.rfind("# vtk DataFile", 0) != 0) r.fail("not a legacy VTK file (no '# vtk DataFile' header)");
  r.next_line(line);  // title
  if (!r.next_line(line) || line.find("ASCII") == std::string::npos) r.fail("only ASCII legacy VTK files are supported");
  std::string t;
  VolumeMesh mesh;
  std::vector<int> cell_vertices;
  std::vector<int> cell_offsets{0};
  std::vector<int> cell_types;
  bool have_dataset = false;
  while (r.token(t)) {
    if (t == "DATASET") {
      r.token(t);
      if (t != "UNSTRUCTURED_GRID") r.fail("DATASET " + t + " is not supported (need UNSTRUCTURED_GRID)");
      have_dataset = true;
    } else if (t == "POINTS") {
      const int n = r.number<int>("point count");
      r.token(t);  // data type
      if (n <= 0) r.fail("no points");
      r.check_count(n, 6, "POINTS");  // "x y z" with one-digit numbers and separators
      mesh.vertices.resize(3 * static_cast<std::size_t>(n));
      for (double& x : mesh.vertices) {
        x = r.number<double>("a coordinate");
        if (!std::isfinite(x)) r.fail("non-finite coordinate");
      }
    } else if (t == "CELLS") {
      const int n = r.number<int>("cell count");
      if (n < 0) r.fail("cell count " + std::to_string(n) + " (a count of at least 0 is expected)");
      r.number<long>("cell list size");
      for (int c = 0; c < n; ++c) {
        const int k = r.number<int>("the vertex count of a cell");
        if (k <= 0 || k > 64) r.fail("bad vertex count " + std::to_string(k));
        for (int j = 0; j < k; ++j) cell_vertices.push_back(r.number<int>("a vertex index"));
        cell_offsets.push_back(static_cast<int>(cell_vertices.size()));
      }
    } else if (t == "CELL_TYPES") {
      const int n = r.number<int>("cell type count");
      if (n < 0) r.fail("cell type count " + std::to_string(n) + " (a count of at least 0 is expected)");
      for (int c = 0; c < n; ++c) cell_types.push_back(r.number<int>("a cell type"));
    } else if (t == "POINT_DATA" || t == "CELL_DATA") {
      break;  // attributes are not needed
    }
  }
  if (!have_dataset) r.fail("no DATASET UNSTRUCTURED_GRID section");
  if (mesh.vertices.empty()) r.fail("no POINTS section");
  if (cell_types.size() + 1 != cell_offsets.size()) r.fail("CELLS and CELL_TYPES counts differ");
  int volume_type = 0;
  for (std::size_t c = 0; c < cell_types.size(); ++c) {
    const int type = cell_types[c];
    if (type != 10 && type != 12) continue;
    if (volume_type && type != volume_type) r.fail("mixed tetrahedra and hexahedra are not supported");
    volume_type = type;
    const int expected = type == 10 ? 4 : 8;
    if (cell_offsets[c + 1] - cell_offsets[c] != expected) r.fail("cell " + std::to_string(c) + " has the wrong vertex count");
    for (int j = cell_offsets[c]; j < cell_offsets[c + 1]; ++j) mesh.cells.push_back(cell_vertices[static_cast<std::size_t>(j)]);
  }
  if (!volume_type) r.fail("no tetrahedra (type 10) or hexahedra (type 12)");
  mesh.type = volume_type == 10 ? CellType::tetrahedron : CellType::hexahedron;
  for (int v : mesh.cells)
    if (v < 0 || v >= mesh.vertex_count()) r.fail("vertex index " + std::to_string(v) + " out of range");
  return mesh;
}

VolumeMesh read_gmsh(std::istream& in, const std::string& path, std::uintmax_t bytes) {
  Reader r(in, path, bytes);
  std::string line;
  if (!r.next_line(line) || line != "$MeshFormat") r.fail("not a Gmsh file (no $MeshFormat)");
  r.next_line(line);
  if (line.rfind("2.", 0) != 0) r.fail("only Gmsh format 2.x ASCII is supported, got '" + line + "'");
  if (line.find(" 0 ") == std::string::npos) r.fail("binary Gmsh files are not supported");
  VolumeMesh mesh;
  std::unordered_map<long, int> node_index;
  int volume_type = 0;
  std::vector<long> cells;
  while (r.next_line(line)) {
    if (line == "$Nodes") {
      if (!mesh.vertices.empty()) r.fail("a second $Nodes section (one is expected)");
      r.reset_tokens();
      const int n = r.number<int>("node count");
      if (n <= 0) r.fail("node count " + std::to_string(n) + " (a positive count is expected)");
      r.check_count(n, 8, "$Nodes count");  // "id x y z" with one-digit numbers and separators
      mesh.vertices.reserve(3 * static_cast<std::size_t>(n));
      for (int i = 0; i < n; ++i) {
        const long id = r.number<long>("a node id");
        if (!node_index.emplace(id, i).second) r.fail("node id " + std::to_string(id) + " appears twice");
        for (int k = 0; k < 3; ++k) {
          mesh.vertices.push_back(r.number<double>("a coordinate"));
          if (!std::isfinite(mesh.vertices.back())) r.fail("non-finite coordinate");
        }
      }
      r.reset_tokens();
    } else if (line == "$Elements") {
      r.reset_tokens();
      const int n = r.number<int>("element count");
      if (n < 0) r.fail("element count " + std::to_string(n) + " (a count of at least 0 is expected)");
      for (int e = 0; e < n; ++e) {
        std::string element;
        if (!r.next_line(element)) r.fail("unexpected end of file in $Elements");
        std::istringstream ss(element);
        long id = 0;
        int type = 0, tags = 0;
        if (!(ss >> id >> type >> tags)) r.fail("malformed element line");
        for (int k = 0; k < tags; ++k) {
          long tag;
          ss >> tag;
        }
        if (type != 4 && type != 5) continue;
        if (volume_type && type != volume_type) r.fail("mixed tetrahedra and hexahedra are not supported");
        volume_type = type;
        const int count = type == 4 ? 4 : 8;
        for (int k = 0; k < count; ++k) {
          long v;
          if (!(ss >> v)) r.fail("element " + std::to_string(id) + " has too few nodes");
          cells.push_back(v);
        }
      }
    }
  }
  if (mesh.vertices.empty()) r.fail("no $Nodes section");
  if (!volume_type) r.fail("no tetrahedra (type 4) or hexahedra (type 5)");
  mesh.type = volume_type == 4 ? CellType::tetrahedron : CellType::hexahedron;
  for (long v : cells) {
    auto it = node_index.find(v);
    if (it == node_index.end()) r.fail("element refers to unknown node " + std::to_string(v));
    mesh.cells.push_back(it->second);
  }
  return mesh;
}

}  // namespace

VolumeMesh read_volume_mesh(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::ios_base::failure("cannot open '" + path + "'");
  const auto dot = path.find_last_of('.');
  const std::string ext = dot == std::string::npos ? "" : path.substr(dot + 1);
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::is_regular_file(path, ec) ? std::filesystem::file_size(path, ec) : 0;
  const std::uintmax_t bytes = ec ? 0 : size;
  if (ext == "vtk") return read_vtk(in, path, bytes);
  if (ext == "msh") return read_gmsh(in, path, bytes);
  throw MeshFormatError(path + ": unsupported mesh format '." + ext + "' (use .vtk or .msh)");
}

void write_vtk_volume_mesh(const std::string& path, const VolumeMesh& mesh) {
  std::ofstream out(path);
  if (!out) throw std::ios_base::failure("cannot write '" + path + "'");
  out.precision(17);
  out << "# vtk DataFile Version 3.0\nfascia volume mesh\nASCII\nDATASET UNSTRUCTURED_GRID\n";
  out << "POINTS " << mesh.vertex_count() << " double\n";
  for (int v = 0; v < mesh.vertex_count(); ++v)
    out << mesh.vertices[3 * v] << " " << mesh.vertices[3 * v + 1] << " " << mesh.vertices[3 * v + 2] << "\n";
  const int k = mesh.nodes_per_cell();
  out << "CELLS " << mesh.cell_count() << " " << mesh.cell_count() * (k + 1) << "\n";
  for (int c = 0; c < mesh.cell_count(); ++c) {
    out << k;
    for (int j = 0; j < k; ++j) out << " " << mesh.cells[static_cast<std::size_t>(c * k + j)];
    out << "\n";
  }
  out << "CELL_TYPES " << mesh.cell_count() << "\n";
  for (int c = 0; c < mesh.cell_count(); ++c) out << (mesh.type == CellType::tetrahedron ? 10 : 12) << "\n";
  if (!out) throw std::ios_base::failure("error writing '" + path + "'");
}

}  // namespace fascia
