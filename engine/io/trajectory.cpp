#include "io/trajectory.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace fascia {

namespace {

// Owns an HDF5 identifier and closes it with the matching H5?close.
class Handle {
 public:
  Handle() = default;
  Handle(hid_t id, herr_t (*close)(hid_t)) : m_id(id), m_close(close) {}
  Handle(Handle&& o) noexcept : m_id(o.m_id), m_close(o.m_close) { o.m_id = H5I_INVALID_HID; }
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      reset();
      m_id = o.m_id;
      m_close = o.m_close;
      o.m_id = H5I_INVALID_HID;
    }
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() { reset(); }
  void reset() {
    if (m_id >= 0 && m_close) m_close(m_id);
    m_id = H5I_INVALID_HID;
  }
  hid_t get() const { return m_id; }
  bool valid() const { return m_id >= 0; }

 private:
  hid_t m_id = H5I_INVALID_HID;
  herr_t (*m_close)(hid_t) = nullptr;
};

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw TrajectoryError(path + ": HDF5 error: " + what);
}

hid_t checked(hid_t id, const std::string& path, const std::string& what) {
  if (id < 0) fail(path, what);
  return id;
}

void checked(herr_t status, const std::string& path, const std::string& what, int) {
  if (status < 0) fail(path, what);
}

Handle group(hid_t parent, const std::string& name, const std::string& path) {
  return Handle(checked(H5Gcreate2(parent, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), path,
                        "create group " + name),
                H5Gclose);
}

Handle string_type(std::size_t size) {
  Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(t.get(), size == 0 ? H5T_VARIABLE : size);
  H5Tset_strpad(t.get(), H5T_STR_NULLTERM);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  return t;
}

void string_attribute(hid_t object, const std::string& name, const std::string& value, const std::string& path) {
  Handle type = string_type(value.size() + 1);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attr(checked(H5Acreate2(object, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), path,
                      "create attribute " + name),
              H5Aclose);
  checked(H5Awrite(attr.get(), type.get(), value.c_str()), path, "write attribute " + name, 0);
}

void int_attribute(hid_t object, const std::string& name, const std::vector<int>& values, const std::string& path) {
  const hsize_t n = values.size();
  Handle space(values.size() == 1 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &n, nullptr), H5Sclose);
  Handle attr(checked(H5Acreate2(object, name.c_str(), H5T_STD_I32LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), path,
                      "create attribute " + name),
              H5Aclose);
  checked(H5Awrite(attr.get(), H5T_NATIVE_INT, values.data()), path, "write attribute " + name, 0);
}

void string_dataset(hid_t parent, const std::string& name, const std::string& value, const std::string& path) {
  Handle type = string_type(0);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle ds(checked(H5Dcreate2(parent, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                    path, "create dataset " + name),
            H5Dclose);
  const char* data = value.c_str();
  checked(H5Dwrite(ds.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, &data), path, "write " + name, 0);
}

// H5MD requires a box in each particles group; ours is open (no periodic boundaries).
void write_box(hid_t particles_group, const std::string& path) {
  Handle box = group(particles_group, "box", path);
  int_attribute(box.get(), "dimension", {3}, path);
  Handle type = string_type(5);
  const hsize_t n = 3;
  Handle space(H5Screate_simple(1, &n, nullptr), H5Sclose);
  Handle attr(checked(H5Acreate2(box.get(), "boundary", type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), path,
                      "create attribute boundary"),
              H5Aclose);
  const char data[3][5] = {"none", "none", "none"};
  checked(H5Awrite(attr.get(), type.get(), data), path, "write attribute boundary", 0);
}

// An extensible dataset [T][shape...] with one chunk per step (arrays) or 256 steps (scalars).
Handle series_dataset(hid_t parent, const std::string& name, hid_t file_type, const std::vector<hsize_t>& shape,
                      const std::string& path) {
  std::vector<hsize_t> dims{0}, maxdims{H5S_UNLIMITED}, chunk{shape.empty() ? hsize_t(256) : hsize_t(1)};
  for (hsize_t s : shape) {
    dims.push_back(s);
    maxdims.push_back(s);
    chunk.push_back(std::max<hsize_t>(s, 1));
  }
  Handle space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), maxdims.data()), H5Sclose);
  Handle plist(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  H5Pset_chunk(plist.get(), static_cast<int>(chunk.size()), chunk.data());
  return Handle(checked(H5Dcreate2(parent, name.c_str(), file_type, space.get(), H5P_DEFAULT, plist.get(), H5P_DEFAULT),
                        path, "create dataset " + name),
                H5Dclose);
}

void append_row(hid_t ds, hid_t mem_type, const void* data, hsize_t row, const std::string& path, const std::string& what) {
  Handle fspace(H5Dget_space(ds), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(fspace.get());
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  H5Sget_simple_extent_dims(fspace.get(), dims.data(), nullptr);
  dims[0] = row + 1;
  checked(H5Dset_extent(ds, dims.data()), path, "extend " + what, 0);
  fspace = Handle(H5Dget_space(ds), H5Sclose);
  std::vector<hsize_t> start(static_cast<std::size_t>(rank), 0), count = dims;
  start[0] = row;
  count[0] = 1;
  checked(H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr), path,
          "select " + what, 0);
  Handle mspace(H5Screate_simple(rank, count.data(), nullptr), H5Sclose);
  checked(H5Dwrite(ds, mem_type, mspace.get(), fspace.get(), H5P_DEFAULT, data), path, "write " + what, 0);
}

struct Series {
  std::string name;
  Handle group, step, time, value;
  hid_t mem_type = H5T_NATIVE_DOUBLE;
  std::size_t count = 1;  // values per step
};

Series make_series(hid_t parent, const std::string& name, const std::vector<hsize_t>& shape, bool integer,
                   const std::string& unit, const std::string& path) {
  Series s;
  s.name = name;
  s.group = group(parent, name, path);
  s.step = series_dataset(s.group.get(), "step", H5T_STD_I32LE, {}, path);
  s.time = series_dataset(s.group.get(), "time", H5T_IEEE_F64LE, {}, path);
  string_attribute(s.time.get(), "unit", "s", path);
  s.value = series_dataset(s.group.get(), "value", integer ? H5T_STD_I32LE : H5T_IEEE_F64LE, shape, path);
  if (!unit.empty()) string_attribute(s.value.get(), "unit", unit, path);
  s.mem_type = integer ? H5T_NATIVE_INT : H5T_NATIVE_DOUBLE;
  for (hsize_t d : shape) s.count *= d;
  return s;
}

}  // namespace

struct TrajectoryWriter::Impl {
  Handle file;
  std::vector<Series> particles;   // frames position, orientation, samples position, surfaces
  std::vector<Series> observables;
};

TrajectoryWriter::TrajectoryWriter(const std::string& path, const TrajectoryHeader& header,
                                   const TrajectoryLayout& layout)
    : m_path(path), m_layout(layout), m_impl(std::make_unique<Impl>()) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors become exceptions with our messages
  m_impl->file = Handle(checked(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), path, "cannot create file"),
                        H5Fclose);
  const hid_t f = m_impl->file.get();

  {
    Handle h5md = group(f, "h5md", path);
    int_attribute(h5md.get(), "version", {1, 1}, path);
    Handle author = group(h5md.get(), "author", path);
    string_attribute(author.get(), "name", header.author.empty() ? "unknown" : header.author, path);
    Handle creator = group(h5md.get(), "creator", path);
    string_attribute(creator.get(), "name", "fascia", path);
    string_attribute(creator.get(), "version", header.creator_version, path);
  }
  {
    Handle parameters = group(f, "parameters", path);
    string_dataset(parameters.get(), "scene", header.scene, path);
    string_dataset(parameters.get(), "scene_file", header.scene_file, path);
    string_dataset(parameters.get(), "command_line", header.command_line, path);
    string_dataset(parameters.get(), "version", header.creator_version, path);
    string_dataset(parameters.get(), "environment", header.environment, path);
  }

  Handle particles = group(f, "particles", path);
  const hsize_t n = static_cast<hsize_t>(layout.frames);
  {
    Handle frames = group(particles.get(), "frames", path);
    write_box(frames.get(), path);
    m_impl->particles.push_back(make_series(frames.get(), "position", {n, 3}, false, "m", path));
    m_impl->particles.push_back(make_series(frames.get(), "orientation", {n, 4}, false, "", path));
  }
  if (layout.samples > 0) {
    Handle samples = group(particles.get(), "samples", path);
    write_box(samples.get(), path);
    m_impl->particles.push_back(
        make_series(samples.get(), "position", {static_cast<hsize_t>(layout.samples), 3}, false, "m", path));
  }
  {
    Handle connectivity = group(f, "connectivity", path);
    // Point clouds get explicit vertex connectivity (0..n-1) so that XDMF readers need not infer it.
    auto vertices = [&](const char* name, int count) {
      std::vector<int> ids(static_cast<std::size_t>(count));
      for (int i = 0; i < count; ++i) ids[static_cast<std::size_t>(i)] = i;
      const hsize_t count_h = ids.size();
      Handle space(H5Screate_simple(1, &count_h, nullptr), H5Sclose);
      Handle ds(checked(H5Dcreate2(connectivity.get(), name, H5T_STD_I32LE, space.get(), H5P_DEFAULT, H5P_DEFAULT,
                                   H5P_DEFAULT),
                        path, std::string("create connectivity of ") + name),
                H5Dclose);
      if (count > 0)
        checked(H5Dwrite(ds.get(), H5T_NATIVE_INT, H5S_ALL, H5S_ALL, H5P_DEFAULT, ids.data()), path,
                std::string("write connectivity of ") + name, 0);
      string_attribute(ds.get(), "cell_type", "vertex", path);
      string_attribute(ds.get(), "particles_group", std::string("/particles/") + name, path);
    };
    vertices("frames", layout.frames);
    if (layout.samples > 0) vertices("samples", layout.samples);
    for (const SurfaceLayout& s : layout.surfaces) {
      if (s.name == "frames" || s.name == "samples") fail(path, "surface name '" + s.name + "' is reserved");
      Handle g = group(particles.get(), s.name, path);
      write_box(g.get(), path);
      const hsize_t v = s.vertex_frames.size();
      m_impl->particles.push_back(make_series(g.get(), "position", {v, 3}, false, "m", path));
      {
        Handle space(H5Screate_simple(1, &v, nullptr), H5Sclose);
        Handle ds(checked(H5Dcreate2(g.get(), "frames", H5T_STD_I32LE, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                          path, "create frames of " + s.name),
                  H5Dclose);
        checked(H5Dwrite(ds.get(), H5T_NATIVE_INT, H5S_ALL, H5S_ALL, H5P_DEFAULT, s.vertex_frames.data()), path,
                "write frames of " + s.name, 0);
      }
      const hsize_t dims[2] = {static_cast<hsize_t>(s.faces.size() / static_cast<std::size_t>(s.nodes_per_face)),
                               static_cast<hsize_t>(s.nodes_per_face)};
      Handle space(H5Screate_simple(2, dims, nullptr), H5Sclose);
      Handle ds(checked(H5Dcreate2(connectivity.get(), s.name.c_str(), H5T_STD_I32LE, space.get(), H5P_DEFAULT,
                                   H5P_DEFAULT, H5P_DEFAULT),
                        path, "create connectivity of " + s.name),
                H5Dclose);
      checked(H5Dwrite(ds.get(), H5T_NATIVE_INT, H5S_ALL, H5S_ALL, H5P_DEFAULT, s.faces.data()), path,
              "write connectivity of " + s.name, 0);
      string_attribute(ds.get(), "cell_type", s.nodes_per_face == 3 ? "triangle" : "quadrilateral", path);
      string_attribute(ds.get(), "particles_group", "/particles/" + s.name, path);
    }
  }
  Handle observables = group(f, "observables", path);
  for (const auto& [name, integer] : layout.observables) {
    std::string unit;
    if (name.find("energy") != std::string::npos || name.find("potential") != std::string::npos) unit = "J";
    if (name == "wall_time") unit = "s";
    m_impl->observables.push_back(make_series(observables.get(), name, {}, integer, unit, path));
  }
  checked(H5Fflush(f, H5F_SCOPE_GLOBAL), path, "flush", 0);
}

TrajectoryWriter::~TrajectoryWriter() {
  try {
    close();
  } catch (...) {
    // destructors must not throw; close() explicitly to see errors
  }
}

void TrajectoryWriter::close() {
  if (!m_impl) return;
  if (m_impl->file.valid()) H5Fflush(m_impl->file.get(), H5F_SCOPE_GLOBAL);
  m_impl->particles.clear();
  m_impl->observables.clear();
  m_impl->file.reset();
  m_impl.reset();
}

void TrajectoryWriter::append(const TrajectoryStep& step) {
  if (!m_impl) throw TrajectoryError(m_path + ": write after close");
  std::vector<std::pair<const double*, std::size_t>> arrays;
  arrays.push_back({step.frame_positions, 3 * static_cast<std::size_t>(m_layout.frames)});
  arrays.push_back({step.frame_orientations, 4 * static_cast<std::size_t>(m_layout.frames)});
  if (m_layout.samples > 0) arrays.push_back({step.sample_positions, 3 * static_cast<std::size_t>(m_layout.samples)});
  if (step.surface_positions.size() != m_layout.surfaces.size())
    throw TrajectoryError(m_path + ": step has " + std::to_string(step.surface_positions.size()) + " surfaces, layout " +
                          std::to_string(m_layout.surfaces.size()));
  for (std::size_t s = 0; s < m_layout.surfaces.size(); ++s)
    arrays.push_back({step.surface_positions[s], 3 * m_layout.surfaces[s].vertex_frames.size()});
  if (step.observables.size() != m_layout.observables.size())
    throw TrajectoryError(m_path + ": step has " + std::to_string(step.observables.size()) + " observables, layout " +
                          std::to_string(m_layout.observables.size()));

  // Check everything before writing anything: a step is written whole or not at all.
  for (const auto& [data, count] : arrays) {
    if (!data && count) throw TrajectoryError(m_path + ": missing data in step " + std::to_string(step.step));
    for (std::size_t i = 0; i < count; ++i)
      if (!std::isfinite(data[i]))
        throw TrajectoryError(m_path + ": refusing to write non-finite values at step " + std::to_string(step.step));
  }
  for (double v : step.observables)
    if (!std::isfinite(v))
      throw TrajectoryError(m_path + ": refusing to write a non-finite observable at step " + std::to_string(step.step));
  if (!std::isfinite(step.time)) throw TrajectoryError(m_path + ": non-finite time");

  const hsize_t row = static_cast<hsize_t>(m_steps);
  auto write_series = [&](Series& s, const void* data) {
    append_row(s.value.get(), s.mem_type, data, row, m_path, s.name + "/value");
    append_row(s.time.get(), H5T_NATIVE_DOUBLE, &step.time, row, m_path, s.name + "/time");
    append_row(s.step.get(), H5T_NATIVE_INT, &step.step, row, m_path, s.name + "/step");
  };
  for (std::size_t i = 0; i < m_impl->particles.size(); ++i) write_series(m_impl->particles[i], arrays[i].first);
  for (std::size_t i = 0; i < m_impl->observables.size(); ++i) {
    Series& s = m_impl->observables[i];
    if (s.mem_type == H5T_NATIVE_INT) {
      const int v = static_cast<int>(std::lround(step.observables[i]));
      write_series(s, &v);
    } else {
      write_series(s, &step.observables[i]);
    }
  }
  checked(H5Fflush(m_impl->file.get(), H5F_SCOPE_GLOBAL), m_path, "flush", 0);
  ++m_steps;
}

// ---------------------------------------------------------------------------------------------
// Reader

namespace {

std::vector<hsize_t> extent(hid_t ds) {
  Handle space(H5Dget_space(ds), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  std::vector<hsize_t> dims(static_cast<std::size_t>(std::max(rank, 0)));
  if (rank > 0) H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
  return dims;
}

std::vector<std::string> children(hid_t parent, const std::string& name) {
  std::vector<std::string> out;
  if (H5Lexists(parent, name.c_str(), H5P_DEFAULT) <= 0) return out;
  Handle g(H5Gopen2(parent, name.c_str(), H5P_DEFAULT), H5Gclose);
  if (!g.valid()) return out;
  H5G_info_t info;
  if (H5Gget_info(g.get(), &info) < 0) return out;
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    const ssize_t size = H5Lget_name_by_idx(g.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, nullptr, 0, H5P_DEFAULT);
    if (size < 0) continue;
    std::string s(static_cast<std::size_t>(size) + 1, '\0');
    H5Lget_name_by_idx(g.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, s.data(), s.size(), H5P_DEFAULT);
    s.resize(static_cast<std::size_t>(size));
    out.push_back(s);
  }
  return out;
}

bool exists(hid_t file, const std::string& path) {
  // H5Lexists needs each intermediate link to exist.
  std::size_t pos = 0;
  while ((pos = path.find('/', pos + 1)) != std::string::npos)
    if (H5Lexists(file, path.substr(0, pos).c_str(), H5P_DEFAULT) <= 0) return false;
  return H5Lexists(file, path.c_str(), H5P_DEFAULT) > 0;
}

std::string read_string_attribute(hid_t object, const std::string& name) {
  if (H5Aexists(object, name.c_str()) <= 0) return "";
  Handle attr(H5Aopen(object, name.c_str(), H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(attr.get()), H5Tclose);
  if (H5Tis_variable_str(type.get()) > 0) {
    char* data = nullptr;
    Handle mem = string_type(0);
    if (H5Aread(attr.get(), mem.get(), &data) < 0 || !data) return "";
    std::string s(data);
    H5free_memory(data);
    return s;
  }
  const std::size_t size = H5Tget_size(type.get());
  std::string s(size, '\0');
  H5Aread(attr.get(), type.get(), s.data());
  s.resize(std::strlen(s.c_str()));
  return s;
}

}  // namespace

struct TrajectoryReader::Impl {
  std::string path;
  Handle file;
  std::vector<std::string> series;  // paths of all time-series groups
};

TrajectoryReader::TrajectoryReader(const std::string& path) : m_impl(std::make_unique<Impl>()) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  m_impl->path = path;
  m_impl->file = Handle(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!m_impl->file.valid()) throw TrajectoryError(path + ": not a readable HDF5 file");
  const hid_t f = m_impl->file.get();
  if (!exists(f, "/h5md")) throw TrajectoryError(path + ": not an H5MD file (no /h5md group)");
  for (const std::string& g : children(f, "/particles"))
    for (const std::string& e : children(f, "/particles/" + g))
      if (exists(f, "/particles/" + g + "/" + e + "/step")) m_impl->series.push_back("/particles/" + g + "/" + e);
  for (const std::string& o : children(f, "/observables"))
    if (exists(f, "/observables/" + o + "/step")) m_impl->series.push_back("/observables/" + o);
  long steps = m_impl->series.empty() ? 0 : std::numeric_limits<long>::max();
  for (const std::string& s : m_impl->series) {
    for (const char* part : {"step", "time", "value"}) {
      Handle ds(H5Dopen2(f, (s + "/" + part).c_str(), H5P_DEFAULT), H5Dclose);
      if (!ds.valid()) throw TrajectoryError(path + ": cannot open " + s + "/" + part);
      steps = std::min<long>(steps, static_cast<long>(extent(ds.get()).at(0)));
    }
  }
  m_steps = static_cast<int>(steps);
}

TrajectoryReader::~TrajectoryReader() = default;

namespace {

template <class T>
std::vector<T> read_rows(hid_t file, const std::string& path, hid_t mem_type, hsize_t first, hsize_t rows,
                         const std::string& file_path) {
  Handle ds(H5Dopen2(file, path.c_str(), H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw TrajectoryError(file_path + ": no dataset " + path);
  std::vector<hsize_t> dims = extent(ds.get());
  if (dims.empty()) dims.push_back(1);
  if (first + rows > dims[0]) throw TrajectoryError(file_path + ": " + path + " has only " + std::to_string(dims[0]) + " rows");
  std::vector<hsize_t> start(dims.size(), 0), count = dims;
  start[0] = first;
  count[0] = rows;
  std::size_t total = 1;
  for (hsize_t c : count) total *= c;
  std::vector<T> out(total);
  if (total == 0) return out;
  Handle fspace(H5Dget_space(ds.get()), H5Sclose);
  H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr);
  Handle mspace(H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr), H5Sclose);
  if (H5Dread(ds.get(), mem_type, mspace.get(), fspace.get(), H5P_DEFAULT, out.data()) < 0)
    throw TrajectoryError(file_path + ": cannot read " + path);
  return out;
}

}  // namespace

std::vector<int> TrajectoryReader::steps() const {
  if (m_impl->series.empty()) return {};
  return read_rows<int>(m_impl->file.get(), m_impl->series.front() + "/step", H5T_NATIVE_INT, 0,
                        static_cast<hsize_t>(m_steps), m_impl->path);
}

std::vector<double> TrajectoryReader::times() const {
  if (m_impl->series.empty()) return {};
  return read_rows<double>(m_impl->file.get(), m_impl->series.front() + "/time", H5T_NATIVE_DOUBLE, 0,
                           static_cast<hsize_t>(m_steps), m_impl->path);
}

std::vector<ParticleGroupInfo> TrajectoryReader::particle_groups() const {
  std::vector<ParticleGroupInfo> out;
  const hid_t f = m_impl->file.get();
  for (const std::string& g : children(f, "/particles")) {
    const std::string p = "/particles/" + g + "/position/value";
    if (!exists(f, p)) continue;
    Handle ds(H5Dopen2(f, p.c_str(), H5P_DEFAULT), H5Dclose);
    const std::vector<hsize_t> dims = extent(ds.get());
    out.push_back({g, dims.size() > 1 ? static_cast<int>(dims[1]) : 0});
  }
  return out;
}

std::vector<std::string> TrajectoryReader::observable_names() const { return children(m_impl->file.get(), "/observables"); }

std::vector<double> TrajectoryReader::observable(const std::string& name) const {
  return read_rows<double>(m_impl->file.get(), "/observables/" + name + "/value", H5T_NATIVE_DOUBLE, 0,
                           static_cast<hsize_t>(m_steps), m_impl->path);
}

std::vector<double> TrajectoryReader::particle_values(const std::string& group, const std::string& element, int k) const {
  if (k < 0 || k >= m_steps) throw TrajectoryError(m_impl->path + ": step index " + std::to_string(k) + " out of range");
  return read_rows<double>(m_impl->file.get(), "/particles/" + group + "/" + element + "/value", H5T_NATIVE_DOUBLE,
                           static_cast<hsize_t>(k), 1, m_impl->path);
}

std::vector<int> TrajectoryReader::connectivity(const std::string& surface, int& nodes_per_face) const {
  const std::string p = "/connectivity/" + surface;
  Handle ds(H5Dopen2(m_impl->file.get(), p.c_str(), H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw TrajectoryError(m_impl->path + ": no " + p);
  const std::vector<hsize_t> dims = extent(ds.get());
  nodes_per_face = dims.size() > 1 ? static_cast<int>(dims[1]) : 0;
  return read_rows<int>(m_impl->file.get(), p, H5T_NATIVE_INT, 0, dims[0], m_impl->path);
}

std::string TrajectoryReader::parameter(const std::string& name) const {
  const std::string p = "/parameters/" + name;
  if (!exists(m_impl->file.get(), p)) return "";
  Handle ds(H5Dopen2(m_impl->file.get(), p.c_str(), H5P_DEFAULT), H5Dclose);
  Handle type = string_type(0);
  char* data = nullptr;
  if (H5Dread(ds.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, &data) < 0 || !data) return "";
  std::string s(data);
  H5free_memory(data);
  return s;
}

std::vector<int> TrajectoryReader::h5md_version() const {
  Handle g(H5Gopen2(m_impl->file.get(), "/h5md", H5P_DEFAULT), H5Gclose);
  if (H5Aexists(g.get(), "version") <= 0) return {};
  Handle attr(H5Aopen(g.get(), "version", H5P_DEFAULT), H5Aclose);
  std::vector<int> v(2, 0);
  H5Aread(attr.get(), H5T_NATIVE_INT, v.data());
  return v;
}

std::string TrajectoryReader::creator_name() const {
  if (!exists(m_impl->file.get(), "/h5md/creator")) return "";
  Handle g(H5Gopen2(m_impl->file.get(), "/h5md/creator", H5P_DEFAULT), H5Gclose);
  return read_string_attribute(g.get(), "name");
}

std::string TrajectoryReader::creator_version() const {
  if (!exists(m_impl->file.get(), "/h5md/creator")) return "";
  Handle g(H5Gopen2(m_impl->file.get(), "/h5md/creator", H5P_DEFAULT), H5Gclose);
  return read_string_attribute(g.get(), "version");
}

}  // namespace fascia
