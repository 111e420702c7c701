#include "io/trajectory.hpp"

#include "io/background_writeback.hpp"
#include "io/hdf5_format.hpp"
#include "io/hdf5_handle.hpp"
#include "io/hdf5_read.hpp"
#include "io/hdf5_text.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

namespace fascia {

namespace {

// HDF5 closes the files still open when the program exits; a file whose last write failed (a
// full disk) cannot be closed, and that clean-up then crashes in H5F__close_cb. Files are closed
// here explicitly, so the clean-up is turned off, before HDF5 is first used.
const bool g_no_exit_cleanup = (H5dont_atexit() >= 0);

// The operating system's reason at the bottom of HDF5's error stack ("No space left on device"),
// or "".
std::string system_reason() {
  std::string reason;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_UPWARD,
      [](unsigned n, const H5E_error2_t* error, void* data) -> herr_t {
        const std::string desc = error->desc ? error->desc : "";
        const std::size_t at = desc.find("error message = '");
        if (n == 0 && at != std::string::npos) {
          const std::size_t begin = at + 17, end = desc.find('\'', begin);
          *static_cast<std::string*>(data) = desc.substr(begin, end == std::string::npos ? end : end - begin);
        }
        return 0;
      },
      &reason);
  return reason;
}

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  (void)g_no_exit_cleanup;
  const std::string reason = system_reason();
  throw TrajectoryError(path + ": HDF5 error: " + what + (reason.empty() ? "" : ": " + reason));
}

hid_t checked(hid_t id, const std::string& path, const std::string& what) {
  if (id < 0) fail(path, what);
  return id;
}

void checked(herr_t status, const std::string& path, const std::string& what, int) {
  if (status < 0) fail(path, what);
}

Handle group(hid_t parent, const std::string& name, const std::string& path) {
  const Handle gcpl = group_creation_properties(path);
  return Handle(checked(H5Gcreate2(parent, name.c_str(), H5P_DEFAULT, gcpl.get(), H5P_DEFAULT), path,
                        "create group " + name),
                H5Gclose);
}

void int_attribute(hid_t object, const std::string& name, const std::vector<int>& values, const std::string& path) {
  const hsize_t n = values.size();
  Handle space(values.size() == 1 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &n, nullptr), H5Sclose);
  Handle attr(checked(H5Acreate2(object, name.c_str(), H5T_STD_I32LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), path,
                      "create attribute " + name),
              H5Aclose);
  checked(H5Awrite(attr.get(), H5T_NATIVE_INT, values.data()), path, "write attribute " + name, 0);
}

// H5MD requires a box in each particles group; ours is open (no periodic boundaries).
void write_box(hid_t particles_group, const std::string& path) {
  Handle box = group(particles_group, "box", path);
  int_attribute(box.get(), "dimension", {3}, path);
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type.get(), 5);
  const hsize_t n = 3;
  Handle space(H5Screate_simple(1, &n, nullptr), H5Sclose);
  Handle attr(checked(H5Acreate2(box.get(), "boundary", type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), path,
                      "create attribute boundary"),
              H5Aclose);
  const char data[3][5] = {"none", "none", "none"};
  checked(H5Awrite(attr.get(), type.get(), data), path, "write attribute boundary", 0);
}

// How a killed run stays readable. Any change of HDF5 metadata (dataset extents, chunk index
// nodes, the end-of-allocation in the superblock) written only in part leaves a file in which even
// earlier steps fail to read ("addr overflow"), and H5Fflush itself is not atomic. So the file's
// structure is fixed before the first step: every dataset is created with room for `capacity`
// rows and all its chunks allocated (H5D_ALLOC_TIME_EARLY), and a step writes raw data only, with
// no chunk cache, so the writes reach the operating system in program order: every series' value,
// then time, then step. Every series is written at every row, so all of them share one `step` and
// one `time` dataset (H5MD's hard links): a row is two writes more than its values. `step` rows
// are -1 (and `time` rows NaN) until written; a killed run leaves those never-completed rows at
// the end, and readers count the leading rows with step >= 0. A run that ends normally, on a
// signal or on a solver failure shrinks every dataset to the written rows. Exceeding the capacity
// doubles it (metadata changes, flushed at once).
Handle series_dataset(hid_t parent, const std::string& name, hid_t file_type, const std::vector<hsize_t>& shape,
                      hsize_t capacity, const std::string& path) {
  // Chunks of about 64 KiB or one row, whichever is larger (fewer chunks to preallocate).
  hsize_t row_bytes = H5Tget_size(file_type);
  for (hsize_t s : shape) row_bytes *= std::max<hsize_t>(s, 1);
  const hsize_t rows_per_chunk = std::max<hsize_t>(1, std::min<hsize_t>(1024, (hsize_t(64) << 10) / row_bytes));
  std::vector<hsize_t> dims{capacity}, maxdims{H5S_UNLIMITED}, chunk{rows_per_chunk};
  for (hsize_t s : shape) {
    dims.push_back(s);
    maxdims.push_back(s);
    chunk.push_back(std::max<hsize_t>(s, 1));
  }
  Handle space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), maxdims.data()), H5Sclose);
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data());
  H5Pset_alloc_time(dcpl.get(), H5D_ALLOC_TIME_EARLY);
  H5Pset_obj_track_times(dcpl.get(), 0);
  if (name == "step") {
    const int fill = -1;
    H5Pset_fill_value(dcpl.get(), H5T_NATIVE_INT, &fill);
    H5Pset_fill_time(dcpl.get(), H5D_FILL_TIME_ALLOC);
  } else if (name == "time") {
    const double fill = std::numeric_limits<double>::quiet_NaN();
    H5Pset_fill_value(dcpl.get(), H5T_NATIVE_DOUBLE, &fill);
    H5Pset_fill_time(dcpl.get(), H5D_FILL_TIME_ALLOC);
  } else {
    H5Pset_fill_time(dcpl.get(), H5D_FILL_TIME_NEVER);  // rows are meaningful once their step is written
  }
  Handle dapl(H5Pcreate(H5P_DATASET_ACCESS), H5Pclose);
  H5Pset_chunk_cache(dapl.get(), 0, 0, 1.0);  // write through, in program order
  return Handle(checked(H5Dcreate2(parent, name.c_str(), file_type, space.get(), H5P_DEFAULT, dcpl.get(), dapl.get()),
                        path, "create dataset " + name),
                H5Dclose);
}

std::vector<hsize_t> dataset_dims(hid_t ds) {
  Handle fspace(H5Dget_space(ds), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(fspace.get());
  std::vector<hsize_t> dims(static_cast<std::size_t>(std::max(rank, 0)));
  if (rank > 0) H5Sget_simple_extent_dims(fspace.get(), dims.data(), nullptr);
  return dims;
}

void set_rows(hid_t ds, hsize_t rows, const std::string& path, const std::string& what) {
  std::vector<hsize_t> dims = dataset_dims(ds);
  dims[0] = rows;
  checked(H5Dset_extent(ds, dims.data()), path, "resize " + what, 0);
}

void write_row(hid_t ds, hid_t mem_type, const void* data, hsize_t row, const std::string& path, const std::string& what) {
  std::vector<hsize_t> dims = dataset_dims(ds);
  Handle fspace(H5Dget_space(ds), H5Sclose);
  std::vector<hsize_t> start(dims.size(), 0), count = dims;
  start[0] = row;
  count[0] = 1;
  checked(H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr), path,
          "select " + what, 0);
  Handle mspace(H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr), H5Sclose);
  checked(H5Dwrite(ds, mem_type, mspace.get(), fspace.get(), H5P_DEFAULT, data), path, "write " + what, 0);
}

struct Series {
  std::string name;
  Handle group, value;
  hid_t mem_type = H5T_NATIVE_DOUBLE;
  std::size_t count = 1;  // values per step
};

// The `step` and `time` datasets every series of a file shares: created in the first series'
// group, hard-linked into the others'.
struct Clock {
  Handle step, time;
  std::string where;  // the first series' group
};

// One time series of the layout: its group, element name, per-step shape, type and unit.
struct SeriesPlan {
  std::string group;  // "/particles/frames", "/observables"
  std::string name;
  std::vector<hsize_t> shape;
  bool integer = false;
  std::string unit;
  bool single = false;  // float32 in the file (a double series otherwise)
};

// The series' values are written from native ints or doubles; a single series' doubles are
// rounded to native floats first (a loop at memory speed, where HDF5's conversion runs at a
// fraction of it).
Series make_series(hid_t parent, const SeriesPlan& plan, hsize_t capacity, Clock& clock, const std::string& path) {
  const std::string& name = plan.name;
  Series s;
  s.name = name;
  s.group = group(parent, name, path);
  if (!clock.step.valid()) {
    clock.step = series_dataset(s.group.get(), "step", H5T_STD_I32LE, {}, capacity, path);
    clock.time = series_dataset(s.group.get(), "time", H5T_IEEE_F64LE, {}, capacity, path);
    write_text_attribute(clock.time.get(), "unit", "s", path);
  } else {
    for (const char* part : {"step", "time"})
      checked(H5Lcreate_hard(clock.step.get(), (clock.where + "/" + part).c_str(), s.group.get(), part, H5P_DEFAULT,
                             H5P_DEFAULT),
              path, "link " + name + "/" + part, 0);
  }
  const hid_t file_type = plan.integer ? H5T_STD_I32LE : plan.single ? H5T_IEEE_F32LE : H5T_IEEE_F64LE;
  s.value = series_dataset(s.group.get(), "value", file_type, plan.shape, capacity, path);
  if (!plan.unit.empty()) write_text_attribute(s.value.get(), "unit", plan.unit, path);
  s.mem_type = plan.integer ? H5T_NATIVE_INT : H5T_NATIVE_DOUBLE;
  for (hsize_t d : plan.shape) s.count *= d;
  return s;
}


// File access for writing: metadata is written only by H5Fflush. With evictions enabled the
// metadata cache may write a chunk index node that points past the end-of-allocation recorded on
// disk while a step is half written, and a run killed then leaves earlier steps unreadable ("addr
// overflow"). Keeping dirty metadata in memory until the flush closes that window except during
// the flush itself.
Handle writer_access(const std::string& path) {
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5AC_cache_config_t cache;
  cache.version = H5AC__CURR_CACHE_CONFIG_VERSION;
  checked(H5Pget_mdc_config(fapl.get(), &cache), path, "get metadata cache configuration", 0);
  cache.incr_mode = H5C_incr__off;
  cache.flash_incr_mode = H5C_flash_incr__off;
  cache.decr_mode = H5C_decr__off;
  cache.evictions_enabled = false;
  cache.set_initial_size = true;
  cache.initial_size = std::min<std::size_t>(cache.max_size, 8u << 20);
  checked(H5Pset_mdc_config(fapl.get(), &cache), path, "set metadata cache configuration", 0);
  set_checksummed_format(fapl.get(), path);
  return fapl;
}

// Opens the shared step and time datasets of the series at `where` (its group's path).
Clock open_clock(hid_t file, const std::string& where, const std::string& path) {
  Handle dapl(H5Pcreate(H5P_DATASET_ACCESS), H5Pclose);
  H5Pset_chunk_cache(dapl.get(), 0, 0, 1.0);  // write through, in program order
  Clock clock;
  clock.where = where;
  clock.step = Handle(checked(H5Dopen2(file, (where + "/step").c_str(), dapl.get()), path, "open " + where + "/step"),
                      H5Dclose);
  clock.time = Handle(checked(H5Dopen2(file, (where + "/time").c_str(), dapl.get()), path, "open " + where + "/time"),
                      H5Dclose);
  return clock;
}

Series open_series(hid_t file, const SeriesPlan& plan, const std::string& path) {
  Series s;
  s.name = plan.name;
  const std::string where = plan.group + "/" + plan.name;
  s.group = Handle(checked(H5Gopen2(file, where.c_str(), H5P_DEFAULT), path, "open " + where), H5Gclose);
  Handle dapl(H5Pcreate(H5P_DATASET_ACCESS), H5Pclose);
  H5Pset_chunk_cache(dapl.get(), 0, 0, 1.0);  // write through, in program order
  auto open = [&](const char* name) {
    return Handle(checked(H5Dopen2(s.group.get(), name, dapl.get()), path, "open " + where + "/" + name), H5Dclose);
  };
  s.value = open("value");
  std::vector<hsize_t> dims = dataset_dims(s.value.get());
  dims.erase(dims.begin());
  if (dims != plan.shape) fail(path, where + " has another shape than this run's (a different scene?)");
  s.mem_type = plan.integer ? H5T_NATIVE_INT : H5T_NATIVE_DOUBLE;
  for (hsize_t d : plan.shape) s.count *= d;
  return s;
}

}  // namespace

std::size_t particle_count(const TrajectoryLayout& layout, const std::string& group) {
  if (group == "frames") return static_cast<std::size_t>(layout.frames);
  if (group == "samples") return static_cast<std::size_t>(layout.samples);
  for (const SurfaceLayout& s : layout.surfaces)
    if (s.name == group) return s.vertex_frames.size();
  return 0;
}

namespace {

// Every time series of a layout, in the order of TrajectoryWriter::append's arrays: frames
// (position, orientation), samples, surfaces, the per-particle fields, then the observables.
std::vector<SeriesPlan> series_plan(const TrajectoryLayout& layout) {
  std::vector<SeriesPlan> plan;
  const hsize_t n = static_cast<hsize_t>(layout.frames);
  plan.push_back({"/particles/frames", "position", {n, 3}, false, "m"});
  plan.push_back({"/particles/frames", "orientation", {n, 4}, false, ""});
  if (layout.samples > 0)
    plan.push_back({"/particles/samples", "position", {static_cast<hsize_t>(layout.samples), 3}, false, "m"});
  for (const SurfaceLayout& s : layout.surfaces)
    plan.push_back({"/particles/" + s.name, "position", {static_cast<hsize_t>(s.vertex_frames.size()), 3}, false, "m"});
  for (const FieldLayout& field : layout.fields) {
    std::vector<hsize_t> shape{static_cast<hsize_t>(particle_count(layout, field.group))};
    if (field.components == 3) shape.push_back(3);
    if (field.components == 9) shape.insert(shape.end(), {3, 3});
    plan.push_back({"/particles/" + field.group, field.name, shape, false, field.unit, field.single});
  }
  for (const auto& [name, integer] : layout.observables) {
    std::string unit;
    if (name.find("energy") != std::string::npos || name.find("potential") != std::string::npos) unit = "J";
    if (name == "wall_time") unit = "s";
    plan.push_back({"/observables", name, {}, integer, unit});
  }
  return plan;
}

// The non-finite values of v[n] (IEEE 754 binary32 or binary64, little-endian): those whose
// exponent field is all ones, tested on the 32-bit word that holds it (a double's high word).
template <class T>
std::uint32_t non_finite(const T* v, std::size_t n) {
  static_assert(sizeof(T) == 4 || sizeof(T) == 8, "binary32 or binary64");
  constexpr std::uint32_t exponent = sizeof(T) == 8 ? 0x7ff00000u : 0x7f800000u;
  std::uint32_t count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    std::uint32_t word;
    if constexpr (sizeof(T) == 8) {
      std::uint64_t bits;
      std::memcpy(&bits, v + i, sizeof bits);
      word = static_cast<std::uint32_t>(bits >> 32);
    } else {
      std::memcpy(&word, v + i, sizeof word);
    }
    count += (word & exponent) == exponent;
  }
  return count;
}

// The non-finite values among what a row writes of data[n]: data itself (out null), or data
// rounded to float into out[n] (a non-finite double rounds to one; so does a finite one beyond
// float's range). In blocks of 32 Ki values on the calling thread's OpenMP team: a row of the
// pelvis at 56 k samples is about 2.7 M values, which one thread of an H200 host rounds and tests
// in about 4 ms.
std::uint32_t non_finite_written(const double* data, std::size_t n, float* out) {
  constexpr std::size_t kBlock = std::size_t(1) << 15;
  const long long blocks = static_cast<long long>((n + kBlock - 1) / kBlock);
  std::uint32_t count = 0;
#pragma omp parallel for schedule(static) reduction(+ : count) if (blocks > 1)
  for (long long b = 0; b < blocks; ++b) {
    const std::size_t first = static_cast<std::size_t>(b) * kBlock, size = std::min(kBlock, n - first);
    if (out) {
      for (std::size_t i = first; i < first + size; ++i) out[i] = static_cast<float>(data[i]);
      count += non_finite(out + first, size);
    } else {
      count += non_finite(data + first, size);
    }
  }
  return count;
}

// The descriptor of an open HDF5 file of the default (sec2) driver, or -1.
int file_descriptor(hid_t file) {
  void* handle = nullptr;
  return H5Fget_vfd_handle(file, H5P_DEFAULT, &handle) >= 0 && handle ? *static_cast<int*>(handle) : -1;
}

}  // namespace

struct TrajectoryWriter::Impl {
  Handle file;
  Clock clock;
  std::vector<Series> series;  // series_plan() order
  std::vector<std::vector<float>> rounded;  // per field: a single field's row in float
  std::unique_ptr<BackgroundWriteback> writeback;  // started after each row
};

TrajectoryWriter::TrajectoryWriter(const std::string& path, const TrajectoryHeader& header,
                                   const TrajectoryLayout& layout)
    : m_path(path), m_layout(layout), m_impl(std::make_unique<Impl>()) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors become exceptions with our messages
  Handle fapl = writer_access(path);
  const Handle fcpl = file_creation_properties(path);
  m_impl->file = Handle(checked(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, fcpl.get(), fapl.get()), path, "cannot create file"),
                        H5Fclose);
  m_impl->writeback = std::make_unique<BackgroundWriteback>(file_descriptor(m_impl->file.get()));
  const hid_t f = m_impl->file.get();

  {
    Handle h5md = group(f, "h5md", path);
    int_attribute(h5md.get(), "version", {1, 1}, path);
    Handle author = group(h5md.get(), "author", path);
    write_text_attribute(author.get(), "name", header.author.empty() ? "unknown" : header.author, path);
    Handle creator = group(h5md.get(), "creator", path);
    write_text_attribute(creator.get(), "name", "fascia", path);
    write_text_attribute(creator.get(), "version", header.creator_version, path);
  }
  {
    Handle parameters = group(f, "parameters", path);
    write_text_dataset(parameters.get(), "scene", header.scene, path);
    write_text_dataset(parameters.get(), "scene_file", header.scene_file, path);
    write_text_dataset(parameters.get(), "command_line", header.command_line, path);
    write_text_dataset(parameters.get(), "version", header.creator_version, path);
    write_text_dataset(parameters.get(), "environment", header.environment, path);
  }

  Handle particles = group(f, "particles", path);
  const hsize_t capacity = static_cast<hsize_t>(std::max(layout.capacity, 1));
  m_capacity = static_cast<int>(capacity);
  {
    Handle frames = group(particles.get(), "frames", path);
    write_box(frames.get(), path);
  }
  if (layout.samples > 0) {
    Handle samples = group(particles.get(), "samples", path);
    write_box(samples.get(), path);
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
      write_text_attribute(ds.get(), "cell_type", "vertex", path);
      write_text_attribute(ds.get(), "particles_group", std::string("/particles/") + name, path);
    };
    vertices("frames", layout.frames);
    if (layout.samples > 0) vertices("samples", layout.samples);
    for (const SurfaceLayout& s : layout.surfaces) {
      if (s.name == "frames" || s.name == "samples") fail(path, "surface name '" + s.name + "' is reserved");
      Handle g = group(particles.get(), s.name, path);
      write_box(g.get(), path);
      const hsize_t v = s.vertex_frames.size();
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
      write_text_attribute(ds.get(), "cell_type", s.nodes_per_face == 3 ? "triangle" : "quadrilateral", path);
      write_text_attribute(ds.get(), "particles_group", "/particles/" + s.name, path);
    }
  }
  for (const FieldLayout& field : layout.fields) {
    const hsize_t count = static_cast<hsize_t>(particle_count(layout, field.group));
    if (count == 0 && field.group != "frames" && field.group != "samples" &&
        std::none_of(layout.surfaces.begin(), layout.surfaces.end(),
                     [&](const SurfaceLayout& s) { return s.name == field.group; }))
      fail(path, "field " + field.name + " names no particle group '" + field.group + "'");
    if (field.components != 1 && field.components != 3 && field.components != 9)
      fail(path, "field " + field.name + " has " + std::to_string(field.components) + " components (1, 3 or 9)");
  }
  Handle observables = group(f, "observables", path);
  for (const SeriesPlan& plan : series_plan(layout)) {
    Handle parent(checked(H5Gopen2(f, plan.group.c_str(), H5P_DEFAULT), path, "open " + plan.group), H5Gclose);
    if (m_impl->series.empty()) m_impl->clock.where = plan.group + "/" + plan.name;
    m_impl->series.push_back(
        make_series(parent.get(), plan, capacity, m_impl->clock, path));
  }
  checked(H5Fflush(f, H5F_SCOPE_GLOBAL), path, "flush", 0);
}

TrajectoryWriter::TrajectoryWriter(const std::string& path, const TrajectoryLayout& layout, int keep_rows)
    : m_path(path), m_layout(layout), m_impl(std::make_unique<Impl>()) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  require_checksummed_format(path);
  Handle fapl = writer_access(path);
  m_impl->file = Handle(checked(H5Fopen(path.c_str(), H5F_ACC_RDWR, fapl.get()), path, "cannot open file for writing"),
                        H5Fclose);
  m_impl->writeback = std::make_unique<BackgroundWriteback>(file_descriptor(m_impl->file.get()));
  const hid_t f = m_impl->file.get();
  for (const SeriesPlan& plan : series_plan(layout)) {
    if (m_impl->series.empty()) m_impl->clock = open_clock(f, plan.group + "/" + plan.name, path);
    m_impl->series.push_back(open_series(f, plan, path));
  }
  const hsize_t rows = dataset_dims(m_impl->clock.step.get()).at(0);
  if (keep_rows < 0 || static_cast<hsize_t>(keep_rows) > rows)
    fail(path, "cannot keep " + std::to_string(keep_rows) + " rows of " + std::to_string(rows));
  m_steps = keep_rows;
  m_capacity = std::max(layout.capacity, keep_rows + 1);
  // Rows past the kept ones are invalidated (step -1, time NaN) before anything new is written,
  // so that no reader takes an old row for a new one, whenever the run is stopped.
  resize_all(static_cast<hsize_t>(m_capacity));
  const Clock& clock = m_impl->clock;
  for (hsize_t row = static_cast<hsize_t>(keep_rows); row < std::min<hsize_t>(rows, m_capacity); ++row) {
    const int step = -1;
    const double time = std::numeric_limits<double>::quiet_NaN();
    write_row(clock.step.get(), H5T_NATIVE_INT, &step, row, path, clock.where + "/step");
    write_row(clock.time.get(), H5T_NATIVE_DOUBLE, &time, row, path, clock.where + "/time");
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

long long TrajectoryWriter::file_id() const { return m_impl ? static_cast<long long>(m_impl->file.get()) : -1; }

void TrajectoryWriter::close() {
  if (!m_impl) return;
  if (m_impl->file.valid()) {
    // Shrink the preallocated rows to the written steps: a finished file has exact lengths.
    try {
      resize_all(static_cast<hsize_t>(m_steps));
    } catch (const TrajectoryError&) {
      m_impl->file.reset();
      m_impl.reset();
      throw;
    }
    H5Fflush(m_impl->file.get(), H5F_SCOPE_GLOBAL);
  }
  m_impl->series.clear();
  m_impl->writeback.reset();
  m_impl->file.reset();
  m_impl.reset();
}

void TrajectoryWriter::append(const TrajectoryStep& step) {
  if (!m_impl) throw TrajectoryError(m_path + ": write after close");
  std::vector<std::pair<const double*, std::size_t>> arrays;
  std::vector<std::string> names;  // of each array, for messages
  arrays.push_back({step.frame_positions, 3 * static_cast<std::size_t>(m_layout.frames)});
  names.push_back("frames/position");
  arrays.push_back({step.frame_orientations, 4 * static_cast<std::size_t>(m_layout.frames)});
  names.push_back("frames/orientation");
  if (m_layout.samples > 0) {
    arrays.push_back({step.sample_positions, 3 * static_cast<std::size_t>(m_layout.samples)});
    names.push_back("samples/position");
  }
  if (step.surface_positions.size() != m_layout.surfaces.size())
    throw TrajectoryError(m_path + ": step has " + std::to_string(step.surface_positions.size()) + " surfaces, layout " +
                          std::to_string(m_layout.surfaces.size()));
  for (std::size_t s = 0; s < m_layout.surfaces.size(); ++s) {
    arrays.push_back({step.surface_positions[s], 3 * m_layout.surfaces[s].vertex_frames.size()});
    names.push_back(m_layout.surfaces[s].name + "/position");
  }
  if (step.fields.size() != m_layout.fields.size())
    throw TrajectoryError(m_path + ": step has " + std::to_string(step.fields.size()) + " fields, layout " +
                          std::to_string(m_layout.fields.size()));
  for (std::size_t i = 0; i < m_layout.fields.size(); ++i) {
    arrays.push_back({step.fields[i], static_cast<std::size_t>(m_layout.fields[i].components) *
                                          particle_count(m_layout, m_layout.fields[i].group)});
    names.push_back(m_layout.fields[i].group + "/" + m_layout.fields[i].name);
  }
  if (step.observables.size() != m_layout.observables.size())
    throw TrajectoryError(m_path + ": step has " + std::to_string(step.observables.size()) + " observables, layout " +
                          std::to_string(m_layout.observables.size()));

  // Check everything before writing anything: a step is written whole or not at all. A single
  // field is rounded to float here and its floats must be finite. The tests count on the bits
  // (non_finite), in 32-bit integer lanes that vectorise on any x86-64.
  const std::size_t first_field = arrays.size() - m_layout.fields.size();
  m_impl->rounded.resize(m_layout.fields.size());
  for (std::size_t a = 0; a < arrays.size(); ++a) {
    const auto& [data, count] = arrays[a];
    if (!data && count) throw TrajectoryError(m_path + ": missing data in step " + std::to_string(step.step));
    float* rounded = nullptr;
    if (a >= first_field && m_layout.fields[a - first_field].single) {
      m_impl->rounded[a - first_field].resize(count);
      rounded = m_impl->rounded[a - first_field].data();
    }
    if (non_finite_written(data, count, rounded) != 0)
      throw NonFiniteStep(m_path + ": refusing to write " +
                          (non_finite(data, count) == 0 ? "values beyond float32's range" : "non-finite values") +
                          " of " + names[a] + " at step " + std::to_string(step.step));
  }
  for (std::size_t i = 0; i < step.observables.size(); ++i)
    if (!std::isfinite(step.observables[i]))
      throw NonFiniteStep(m_path + ": refusing to write a non-finite " + m_layout.observables[i].first + " at step " +
                          std::to_string(step.step));
  if (!std::isfinite(step.time)) throw NonFiniteStep(m_path + ": non-finite time");

  const hsize_t row = static_cast<hsize_t>(m_steps);
  if (m_steps >= m_capacity) {
    // Out of preallocated rows: double them (a metadata change, flushed before any data lands).
    m_capacity *= 2;
    resize_all(static_cast<hsize_t>(m_capacity));
    checked(H5Fflush(m_impl->file.get(), H5F_SCOPE_GLOBAL), m_path, "flush", 0);
  }
  auto write_series = [&](Series& s, const void* data) {
    write_row(s.value.get(), s.mem_type, data, row, m_path, s.name + "/value");
  };
  const std::size_t particles = arrays.size();
  for (std::size_t i = 0; i < particles; ++i) {
    Series& s = m_impl->series[i];
    if (i >= first_field && m_layout.fields[i - first_field].single)  // its floats, rounded above
      write_row(s.value.get(), H5T_NATIVE_FLOAT, m_impl->rounded[i - first_field].data(), row, m_path,
                s.name + "/value");
    else
      write_series(s, arrays[i].first);
  }
  for (std::size_t i = 0; i < step.observables.size(); ++i) {
    Series& s = m_impl->series[particles + i];
    if (s.mem_type == H5T_NATIVE_INT) {
      const int v = static_cast<int>(std::lround(step.observables[i]));
      write_series(s, &v);
    } else {
      write_series(s, &step.observables[i]);
    }
  }
  // The row is complete once its step is written.
  const Clock& clock = m_impl->clock;
  write_row(clock.time.get(), H5T_NATIVE_DOUBLE, &step.time, row, m_path, clock.where + "/time");
  write_row(clock.step.get(), H5T_NATIVE_INT, &step.step, row, m_path, clock.where + "/step");
  checked(H5Fflush(m_impl->file.get(), H5F_SCOPE_GLOBAL), m_path, "flush", 0);
  m_impl->writeback->request();
  ++m_steps;
}

void TrajectoryWriter::resize_all(unsigned long long rows) {
  for (Series& s : m_impl->series) set_rows(s.value.get(), rows, m_path, s.name + "/value");
  set_rows(m_impl->clock.time.get(), rows, m_path, m_impl->clock.where + "/time");
  set_rows(m_impl->clock.step.get(), rows, m_path, m_impl->clock.where + "/step");
}

// ---------------------------------------------------------------------------------------------
// Reader

namespace {

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

}  // namespace

namespace {

template <class T>
std::vector<T> read_rows(hid_t file, const std::string& path, hid_t mem_type, hsize_t first, hsize_t rows,
                         const std::string& file_path) {
  Handle ds(H5Dopen2(file, path.c_str(), H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw TrajectoryError(file_path + ": no dataset " + path);
  const std::vector<hsize_t> dims = dataset_extent(ds.get(), file_path, path);
  if (dims.empty()) throw TrajectoryError(file_path + ": " + path + " is a scalar, not a series (corrupt)");
  if (first + rows > dims[0]) throw TrajectoryError(file_path + ": " + path + " has only " + std::to_string(dims[0]) + " rows");
  std::vector<hsize_t> start(dims.size(), 0), count = dims;
  start[0] = first;
  count[0] = rows;
  double total = 1;
  for (hsize_t c : count) total *= static_cast<double>(c);
  // The stored elements' size (float32 fields hold 4 bytes each), at most the read type's.
  Handle stored(H5Dget_type(ds.get()), H5Tclose);
  const double element = stored.valid() ? static_cast<double>(std::min<std::size_t>(H5Tget_size(stored.get()), sizeof(T)))
                                        : static_cast<double>(sizeof(T));
  check_fits_file(ds.get(), total * element, file_path, path);
  std::vector<T> out(static_cast<std::size_t>(total));
  if (total == 0) return out;
  Handle fspace(H5Dget_space(ds.get()), H5Sclose);
  H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr);
  Handle mspace(H5Screate_simple(static_cast<int>(count.size()), count.data(), nullptr), H5Sclose);
  if (H5Dread(ds.get(), mem_type, mspace.get(), fspace.get(), H5P_DEFAULT, out.data()) < 0)
    throw TrajectoryError(file_path + ": cannot read " + path);
  return out;
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
  require_checksummed_format(path);
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
      const std::string name = s + "/" + part;
      Handle ds(H5Dopen2(f, name.c_str(), H5P_DEFAULT), H5Dclose);
      if (!ds.valid()) throw TrajectoryError(path + ": cannot open " + name);
      const std::vector<hsize_t> dims = dataset_extent(ds.get(), path, name);
      if (dims.empty()) throw TrajectoryError(path + ": " + name + " is a scalar, not a series (corrupt)");
      steps = std::min<long>(steps, static_cast<long>(std::min<hsize_t>(dims[0], std::numeric_limits<int>::max())));
    }
  }
  // A killed run leaves preallocated rows whose step was never written (-1): not complete.
  for (const std::string& s : m_impl->series) {
    const std::vector<int> rows =
        read_rows<int>(f, s + "/step", H5T_NATIVE_INT, 0, static_cast<hsize_t>(steps), path);
    long valid = 0;
    while (valid < steps && rows[static_cast<std::size_t>(valid)] >= 0) ++valid;
    steps = valid;
  }
  m_steps = static_cast<int>(steps);
}

TrajectoryReader::~TrajectoryReader() = default;


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
    if (!ds.valid()) throw TrajectoryError(m_impl->path + ": cannot open " + p);
    const std::vector<hsize_t> dims = dataset_extent(ds.get(), m_impl->path, p);
    if (dims.size() != 3 || dims[1] > static_cast<hsize_t>(std::numeric_limits<int>::max()))
      throw TrajectoryError(m_impl->path + ": " + p + " is not a series of particle positions (corrupt)");
    out.push_back({g, static_cast<int>(dims[1])});
  }
  return out;
}

std::vector<std::string> TrajectoryReader::particle_elements(const std::string& group) const {
  std::vector<std::string> out;
  for (const std::string& e : children(m_impl->file.get(), "/particles/" + group))
    if (exists(m_impl->file.get(), "/particles/" + group + "/" + e + "/value")) out.push_back(e);
  return out;
}

std::vector<std::string> TrajectoryReader::observable_names() const { return children(m_impl->file.get(), "/observables"); }

std::vector<double> TrajectoryReader::observable(const std::string& name) const {
  return read_rows<double>(m_impl->file.get(), "/observables/" + name + "/value", H5T_NATIVE_DOUBLE, 0,
                           static_cast<hsize_t>(m_steps), m_impl->path);
}

bool TrajectoryReader::observable_is_integer(const std::string& name) const {
  const std::string path = "/observables/" + name + "/value";
  Handle ds(H5Dopen2(m_impl->file.get(), path.c_str(), H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw TrajectoryError(m_impl->path + ": no dataset " + path);
  Handle type(H5Dget_type(ds.get()), H5Tclose);
  return type.valid() && H5Tget_class(type.get()) == H5T_INTEGER;
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
  const std::vector<hsize_t> dims = dataset_extent(ds.get(), m_impl->path, p);
  if (dims.size() != 2 || (dims[1] != 3 && dims[1] != 4))
    throw TrajectoryError(m_impl->path + ": " + p + " is not a table of triangles or quadrilaterals (corrupt)");
  nodes_per_face = static_cast<int>(dims[1]);
  return read_rows<int>(m_impl->file.get(), p, H5T_NATIVE_INT, 0, dims[0], m_impl->path);
}

std::string TrajectoryReader::parameter(const std::string& name) const {
  const std::string p = "/parameters/" + name;
  if (!exists(m_impl->file.get(), p)) return "";
  return read_text_dataset(m_impl->file.get(), p, m_impl->path);
}

std::vector<int> TrajectoryReader::h5md_version() const {
  Handle g(H5Gopen2(m_impl->file.get(), "/h5md", H5P_DEFAULT), H5Gclose);
  if (!g.valid()) throw TrajectoryError(m_impl->path + ": cannot open /h5md");
  if (H5Aexists(g.get(), "version") <= 0) return {};
  Handle attr(H5Aopen(g.get(), "version", H5P_DEFAULT), H5Aclose);
  std::vector<int> v(2, 0);
  read_attribute_exact(attr.get(), H5T_NATIVE_INT, {2}, v.data(), m_impl->path, "/h5md version");
  return v;
}

std::string TrajectoryReader::creator_name() const { return creator_attribute("name"); }

std::string TrajectoryReader::creator_version() const { return creator_attribute("version"); }

std::string TrajectoryReader::creator_attribute(const std::string& name) const {
  if (!exists(m_impl->file.get(), "/h5md/creator")) return "";
  Handle g(H5Gopen2(m_impl->file.get(), "/h5md/creator", H5P_DEFAULT), H5Gclose);
  if (!g.valid()) throw TrajectoryError(m_impl->path + ": cannot open /h5md/creator");
  if (H5Aexists(g.get(), name.c_str()) <= 0) return "";
  return read_text_attribute(g.get(), name, m_impl->path);
}

}  // namespace fascia
