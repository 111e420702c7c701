#include "io/checkpoint.hpp"

#include "io/hdf5_format.hpp"
#include "io/hdf5_handle.hpp"
#include "io/hdf5_read.hpp"
#include "io/hdf5_text.hpp"
#include "io/trajectory.hpp"
#include "solve/diagonal_shifts.hpp"

#include <hdf5.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <vector>

namespace fascia {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw TrajectoryError(path + ": checkpoint: " + what);
}

hid_t checked(hid_t id, const std::string& path, const std::string& what) {
  if (id < 0) fail(path, what);
  return id;
}

// A fixed-size dataset whose storage is allocated now: later writes touch raw data only.
void fixed_dataset(hid_t parent, const char* name, hid_t type, const std::vector<hsize_t>& dims,
                   const std::string& path) {
  Handle space(dims.empty() ? H5Screate(H5S_SCALAR) : H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr),
               H5Sclose);
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  H5Pset_layout(dcpl.get(), H5D_CONTIGUOUS);
  H5Pset_alloc_time(dcpl.get(), H5D_ALLOC_TIME_EARLY);
  H5Pset_fill_time(dcpl.get(), H5D_FILL_TIME_ALLOC);  // zero: the commit record reads "none yet"
  H5Pset_obj_track_times(dcpl.get(), 0);
  Handle ds(checked(H5Dcreate2(parent, name, type, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT), path,
                    std::string("create ") + name),
            H5Dclose);
}

void int_attribute(hid_t object, const char* name, int value, const std::string& path) {
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attr(checked(H5Acreate2(object, name, H5T_STD_I32LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), path,
                      std::string("create attribute ") + name),
              H5Aclose);
  if (H5Awrite(attr.get(), H5T_NATIVE_INT, &value) < 0) fail(path, std::string("write attribute ") + name);
}

int read_int_attribute(hid_t object, const char* name, const std::string& path) {
  Handle attr(checked(H5Aopen(object, name, H5P_DEFAULT), path, std::string("open attribute ") + name), H5Aclose);
  int value = 0;
  read_attribute_exact(attr.get(), H5T_NATIVE_INT, {}, &value, path, std::string("checkpoint attribute ") + name);
  return value;
}

void write_data(hid_t parent, const char* name, hid_t mem_type, const void* data, const std::string& path) {
  Handle ds(checked(H5Dopen2(parent, name, H5P_DEFAULT), path, std::string("open ") + name), H5Dclose);
  if (H5Dwrite(ds.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) fail(path, std::string("write ") + name);
}

// Reads dataset `name`, of extent `dims`, into `data`.
void read_data(hid_t parent, const char* name, hid_t mem_type, const std::vector<hsize_t>& dims, void* data,
               const std::string& path) {
  Handle ds(checked(H5Dopen2(parent, name, H5P_DEFAULT), path, std::string("open ") + name), H5Dclose);
  read_exact(ds.get(), mem_type, dims, data, path, std::string("checkpoint dataset ") + name);
}

// Flushes HDF5's buffers to the operating system, then the operating system's to the disk.
void flush_and_sync(hid_t file, const std::string& path) {
  if (H5Fflush(file, H5F_SCOPE_GLOBAL) < 0) fail(path, "flush");
  void* handle = nullptr;
  if (H5Fget_vfd_handle(file, H5P_DEFAULT, &handle) < 0 || !handle) fail(path, "no file descriptor to sync");
  if (::fsync(*static_cast<int*>(handle)) != 0) fail(path, "fsync failed");
}

// A state's three datasets, named prefix + positions | orientations | velocities.
void create_state(hid_t slot, const std::string& prefix, hsize_t n, const std::string& path) {
  fixed_dataset(slot, (prefix + "positions").c_str(), H5T_IEEE_F64LE, {n, 3}, path);
  fixed_dataset(slot, (prefix + "orientations").c_str(), H5T_IEEE_F64LE, {n, 4}, path);
  fixed_dataset(slot, (prefix + "velocities").c_str(), H5T_IEEE_F64LE, {n, 6}, path);
}

// An empty state is written as zeros (a tangent origin that is not held, a static step's start).
void write_state(hid_t slot, const std::string& prefix, const State& state, std::size_t n, const std::string& path) {
  const State zeros = state.positions.empty() ? State{std::vector<double>(3 * n, 0.0), std::vector<double>(4 * n, 0.0),
                                                      std::vector<double>(6 * n, 0.0)}
                                              : State{};
  const State& s = state.positions.empty() ? zeros : state;
  if (s.positions.size() != 3 * n || s.orientations.size() != 4 * n || s.velocities.size() != 6 * n)
    fail(path, prefix + "state of " + std::to_string(s.frame_count()) + " frames, file made for " + std::to_string(n));
  write_data(slot, (prefix + "positions").c_str(), H5T_NATIVE_DOUBLE, s.positions.data(), path);
  write_data(slot, (prefix + "orientations").c_str(), H5T_NATIVE_DOUBLE, s.orientations.data(), path);
  write_data(slot, (prefix + "velocities").c_str(), H5T_NATIVE_DOUBLE, s.velocities.data(), path);
}

State read_state(hid_t slot, const std::string& prefix, std::size_t n, const std::string& path) {
  State s;
  s.positions.resize(3 * n);
  s.orientations.resize(4 * n);
  s.velocities.resize(6 * n);
  const hsize_t rows = n;
  read_data(slot, (prefix + "positions").c_str(), H5T_NATIVE_DOUBLE, {rows, 3}, s.positions.data(), path);
  read_data(slot, (prefix + "orientations").c_str(), H5T_NATIVE_DOUBLE, {rows, 4}, s.orientations.data(), path);
  read_data(slot, (prefix + "velocities").c_str(), H5T_NATIVE_DOUBLE, {rows, 6}, s.velocities.data(), path);
  for (const std::vector<double>* v : {&s.positions, &s.orientations, &s.velocities})
    for (double x : *v)
      if (!std::isfinite(x)) fail(path, "non-finite values in the committed " + prefix + "state");
  return s;
}

const char* slot_name(long long sequence) { return sequence % 2 == 0 ? "slot_0" : "slot_1"; }

}  // namespace

CheckpointWriter CheckpointWriter::create(long long file_id, const std::string& path, int frames,
                                          const CheckpointIdentity& identity) {
  const hid_t f = static_cast<hid_t>(file_id);
  const Handle gcpl = group_creation_properties(path);
  Handle group(checked(H5Gcreate2(f, "checkpoint", H5P_DEFAULT, gcpl.get(), H5P_DEFAULT), path, "create /checkpoint"),
               H5Gclose);
  int_attribute(group.get(), "format", kCheckpointFormat, path);
  int_attribute(group.get(), "frames", frames, path);
  write_text_dataset(group.get(), "scene", identity.scene, path);
  write_text_dataset(group.get(), "build", identity.build, path);
  const hsize_t n = static_cast<hsize_t>(frames);
  for (const char* slot : {"slot_0", "slot_1"}) {
    Handle g(checked(H5Gcreate2(group.get(), slot, H5P_DEFAULT, gcpl.get(), H5P_DEFAULT), path,
                     std::string("create ") + slot),
             H5Gclose);
    fixed_dataset(g.get(), "counters", H5T_STD_I64LE, {4}, path);
    fixed_dataset(g.get(), "clock", H5T_IEEE_F64LE, {2}, path);
    create_state(g.get(), "", n, path);
    fixed_dataset(g.get(), "tangent", H5T_STD_I64LE, {5}, path);
    fixed_dataset(g.get(), "tangent_clock", H5T_IEEE_F64LE, {2}, path);
    create_state(g.get(), "tangent_start_", n, path);
    create_state(g.get(), "tangent_", n, path);
    fixed_dataset(g.get(), "controller", H5T_IEEE_F64LE, {2}, path);
    fixed_dataset(g.get(), "controller_counts", H5T_STD_I64LE, {6}, path);
    fixed_dataset(g.get(), "history", H5T_IEEE_F64LE, {1}, path);
    create_state(g.get(), "history_", n, path);
  }
  fixed_dataset(group.get(), "commit", H5T_STD_I64LE, {2}, path);
  return CheckpointWriter(file_id, path, frames, 0);
}

CheckpointWriter CheckpointWriter::open(long long file_id, const std::string& path) {
  const hid_t f = static_cast<hid_t>(file_id);
  Handle group(checked(H5Gopen2(f, "checkpoint", H5P_DEFAULT), path, "open /checkpoint"), H5Gclose);
  const int frames = read_int_attribute(group.get(), "frames", path);
  long long commit[2] = {0, 0};
  read_data(group.get(), "commit", H5T_NATIVE_LLONG, {2}, commit, path);
  return CheckpointWriter(file_id, path, frames, commit[0]);
}

void CheckpointWriter::write(const Checkpoint& c) {
  const std::size_t n = static_cast<std::size_t>(m_frames);
  if (c.state.positions.size() != 3 * n || c.state.orientations.size() != 4 * n || c.state.velocities.size() != 6 * n)
    fail(m_path, "state of " + std::to_string(c.state.frame_count()) + " frames, file made for " +
                     std::to_string(m_frames));
  const hid_t f = static_cast<hid_t>(m_file);
  const long long sequence = m_sequence + 1;
  Handle group(checked(H5Gopen2(f, "checkpoint", H5P_DEFAULT), m_path, "open /checkpoint"), H5Gclose);
  {
    Handle slot(checked(H5Gopen2(group.get(), slot_name(sequence), H5P_DEFAULT), m_path, "open slot"), H5Gclose);
    const long long counters[4] = {sequence, c.step, c.rows, c.finished ? 1 : 0};
    const double clock[2] = {c.time, c.dt};
    write_data(slot.get(), "counters", H5T_NATIVE_LLONG, counters, m_path);
    write_data(slot.get(), "clock", H5T_NATIVE_DOUBLE, clock, m_path);
    write_state(slot.get(), "", c.state, n, m_path);
    const ReusedTangent& t = c.tangent;
    long long tangent[5] = {t.held ? 1 : 0, 0, t.held ? t.solves : 0, t.held ? t.iterations : 0, t.shift_step};
    std::memcpy(&tangent[1], &t.pattern, sizeof t.pattern);
    const double tangent_clock[2] = {t.origin.dt, t.origin.load_scale};
    write_data(slot.get(), "tangent", H5T_NATIVE_LLONG, tangent, m_path);
    write_data(slot.get(), "tangent_clock", H5T_NATIVE_DOUBLE, tangent_clock, m_path);
    write_state(slot.get(), "tangent_start_", t.held ? t.origin.start : State{}, n, m_path);
    write_state(slot.get(), "tangent_", t.held ? t.origin.state : State{}, n, m_path);
    const double controller[2] = {c.controller.dt, c.controller.after_rejection ? 1.0 : 0.0};
    const long long counts[6] = {c.controller.accepted,        c.controller.rejected,
                                 c.progress.newton_iterations, c.progress.cg_iterations,
                                 c.progress.accepted,          c.progress.rejected};
    write_data(slot.get(), "controller", H5T_NATIVE_DOUBLE, controller, m_path);
    write_data(slot.get(), "controller_counts", H5T_NATIVE_LLONG, counts, m_path);
    const bool history_held = c.history.held();
    const double history_dt = history_held ? c.history.dt : 0.0;
    write_data(slot.get(), "history", H5T_NATIVE_DOUBLE, &history_dt, m_path);
    write_state(slot.get(), "history_", history_held ? c.history.previous : State{}, n, m_path);
  }
  flush_and_sync(f, m_path);
  const long long commit[2] = {sequence, c.step};
  write_data(group.get(), "commit", H5T_NATIVE_LLONG, commit, m_path);
  flush_and_sync(f, m_path);
  m_sequence = sequence;
}

std::optional<Checkpoint> read_checkpoint(const std::string& path, CheckpointIdentity* identity) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  require_checksummed_format(path);
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.valid()) throw TrajectoryError(path + ": not a readable HDF5 file");
  if (H5Lexists(file.get(), "checkpoint", H5P_DEFAULT) <= 0) return std::nullopt;
  Handle group(checked(H5Gopen2(file.get(), "checkpoint", H5P_DEFAULT), path, "open /checkpoint"), H5Gclose);
  const int format = read_int_attribute(group.get(), "format", path);
  if (format != kCheckpointFormat)
    fail(path, "format " + std::to_string(format) + ", this build reads format " + std::to_string(kCheckpointFormat) +
                   " (resume with the build that wrote it)");
  if (identity) {
    identity->scene = read_text_dataset(group.get(), "scene", path);
    identity->build = read_text_dataset(group.get(), "build", path);
  }
  long long commit[2] = {0, 0};
  read_data(group.get(), "commit", H5T_NATIVE_LLONG, {2}, commit, path);
  if (commit[0] <= 0) return std::nullopt;
  const int frames = read_int_attribute(group.get(), "frames", path);
  Handle slot(checked(H5Gopen2(group.get(), slot_name(commit[0]), H5P_DEFAULT), path, "open slot"), H5Gclose);
  Checkpoint c;
  long long counters[4] = {0, 0, 0, 0};
  double clock[2] = {0, 0};
  read_data(slot.get(), "counters", H5T_NATIVE_LLONG, {4}, counters, path);
  read_data(slot.get(), "clock", H5T_NATIVE_DOUBLE, {2}, clock, path);
  const long long sequence = counters[0], step = counters[1], rows = counters[2], finished = counters[3];
  if (sequence != commit[0] || step != commit[1])
    fail(path, "the committed record (sequence " + std::to_string(commit[0]) + ") and its slot (sequence " +
                   std::to_string(sequence) + ") disagree");
  c.sequence = sequence;
  c.step = static_cast<int>(step);
  c.rows = static_cast<int>(rows);
  c.finished = finished != 0;
  c.time = clock[0];
  c.dt = clock[1];
  // The frame count sizes the buffers: checked against the file before they are allocated.
  if (frames < 0) fail(path, "negative frame count " + std::to_string(frames) + " (corrupt)");
  check_fits_file(slot.get(), 13.0 * 8.0 * static_cast<double>(frames), path,
                  "checkpoint of " + std::to_string(frames) + " frames");
  const std::size_t n = static_cast<std::size_t>(frames);
  c.state = read_state(slot.get(), "", n, path);
  long long tangent[5] = {0, 0, 0, 0, -1};
  double tangent_clock[2] = {0, 1};
  read_data(slot.get(), "tangent", H5T_NATIVE_LLONG, {5}, tangent, path);
  if (tangent[4] < -1 || tangent[4] >= kShiftSteps)
    fail(path, "tangent shift step " + std::to_string(tangent[4]) + " (corrupt)");
  read_data(slot.get(), "tangent_clock", H5T_NATIVE_DOUBLE, {2}, tangent_clock, path);
  double controller[2] = {0, 0};
  long long counts[6] = {0, 0, 0, 0, 0, 0};
  read_data(slot.get(), "controller", H5T_NATIVE_DOUBLE, {2}, controller, path);
  read_data(slot.get(), "controller_counts", H5T_NATIVE_LLONG, {6}, counts, path);
  c.controller.dt = controller[0];
  c.controller.after_rejection = controller[1] != 0;
  c.controller.accepted = static_cast<long>(counts[0]);
  c.controller.rejected = static_cast<long>(counts[1]);
  c.progress = AdvanceProgress{static_cast<long>(counts[2]), static_cast<long>(counts[3]), static_cast<long>(counts[4]),
                               static_cast<long>(counts[5])};
  double history_dt = 0;
  read_data(slot.get(), "history", H5T_NATIVE_DOUBLE, {1}, &history_dt, path);
  if (!std::isfinite(history_dt) || history_dt < 0)
    fail(path, "path history step " + std::to_string(history_dt) + " (corrupt)");
  if (history_dt > 0) {
    c.history.dt = history_dt;
    c.history.previous = read_state(slot.get(), "history_", n, path);
  }
  c.tangent.held = tangent[0] != 0;
  c.tangent.shift_step = static_cast<int>(tangent[4]);
  if (c.tangent.held) {
    std::memcpy(&c.tangent.pattern, &tangent[1], sizeof c.tangent.pattern);
    c.tangent.solves = static_cast<int>(tangent[2]);
    c.tangent.iterations = tangent[3];
    c.tangent.origin.dt = tangent_clock[0];
    c.tangent.origin.load_scale = tangent_clock[1];
    c.tangent.origin.start = read_state(slot.get(), "tangent_start_", n, path);
    c.tangent.origin.state = read_state(slot.get(), "tangent_", n, path);
  }
  return c;
}

}  // namespace fascia
