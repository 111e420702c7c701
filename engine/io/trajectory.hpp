// HDF5 trajectories in the H5MD 1.1 layout (DESIGN.md "Output"):
//
//   /h5md                         attributes version = [1, 1]; groups author{name}, creator{name, version}
//   /particles/frames/            box{dimension, boundary}; position, orientation (w, x, y, z)
//   /particles/samples/           box; position
//   /particles/<surface>/         box; position (surface vertices); frames [V] (frame of each vertex)
//   /particles/<group>/<field>/   per-particle fields of frames, samples or a surface (layout.fields):
//                                 value [T][n], [T][n][3] or [T][n][3][3], with a unit attribute;
//                                 float64, or float32 for a field marked single
//   /connectivity/<surface>       [F][3|4] int, indices into /particles/<surface>/position
//   /connectivity/frames, samples [n] int, 0..n-1 (vertex cells for XDMF point clouds)
//   /observables/<name>/          step, time, value [T]
//   /parameters/                  scene (resolved YAML), scene_file, command_line, version, environment
//   /checkpoint/                  the state to continue the run from (io/checkpoint.hpp)
//
// Each time-dependent element is a group {step [T] int32, time [T] float64, value [T][...]},
// chunked and unlimited in T. A step is written value -> time -> step for every element, then
// the file is flushed (H5Fflush). To survive kill -9 at any moment the rows are preallocated
// (see trajectory.cpp): a finished, stopped or failed run has datasets of exactly T rows; a killed
// run keeps trailing rows whose step is -1 (time NaN). Readers take as complete the leading rows
// with step >= 0 common to all elements (and never more than the shortest dataset).
#pragma once

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace fascia {

// HDF5 failure (cannot create, write or read); what() names the file and the operation.
class TrajectoryError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A step holding a non-finite value (a diverged state, or magnitudes beyond a double): refused,
// nothing of it written. The message names the dataset.
class NonFiniteStep : public TrajectoryError {
 public:
  using TrajectoryError::TrajectoryError;
};

struct TrajectoryHeader {
  std::string creator_version;  // fascia version
  std::string author;           // user name, when known
  std::string scene;            // resolved scene (YAML)
  std::string scene_file;
  std::string command_line;
  std::string environment;      // JSON text: host, job ids, threads, ...
};

struct SurfaceLayout {
  std::string name;             // object name: /particles/<name>, /connectivity/<name>
  int nodes_per_face = 3;       // 3 triangles, 4 quadrilaterals
  std::vector<int> faces;       // [F][nodes_per_face]
  std::vector<int> vertex_frames;  // [V] frame of each surface vertex (mesh-based: identity on the boundary)
};

// A per-particle field written each step as /particles/<group>/<name>/{step, time, value}: value
// [T][n] (scalar), [T][n][3] (vector) or [T][n][3][3] (tensor, row-major), n the group's particles.
struct FieldLayout {
  std::string group;        // "frames", "samples" or a surface name
  std::string name;         // e.g. "displacement", "cauchy_stress"
  int components = 1;       // 1 scalar, 3 vector, 9 tensor (3 x 3)
  std::string unit;         // SI unit ("" dimensionless)
  bool single = false;      // stored as float32 (written from doubles, read back as doubles)
};

struct TrajectoryLayout {
  int frames = 0;
  int samples = 0;  // 0: no /particles/samples
  std::vector<SurfaceLayout> surfaces;
  // Observables recorded each step, in this order; integers are stored as int32.
  std::vector<std::pair<std::string, bool>> observables;  // (name, is_integer)
  std::vector<FieldLayout> fields;  // per-particle fields, in this order
  // Rows preallocated for the steps to come (doubled when exceeded): the number of output steps
  // the run plans, plus one for a step written on a signal.
  int capacity = 16;
};

struct TrajectoryStep {
  int step = 0;
  double time = 0;
  const double* frame_positions = nullptr;     // [N][3]
  const double* frame_orientations = nullptr;  // [N][4]
  const double* sample_positions = nullptr;    // [S][3], when layout.samples > 0
  std::vector<const double*> surface_positions;  // per surface [V][3]
  std::vector<double> observables;             // in layout order
  std::vector<const double*> fields;           // per layout.fields entry: [n][components]
};

// Particles of a group in the layout: frames, samples or a surface's vertices (0 if unknown).
std::size_t particle_count(const TrajectoryLayout& layout, const std::string& group);

class TrajectoryWriter {
 public:
  // Creates (truncates) the file and writes /h5md, /parameters and /connectivity.
  TrajectoryWriter(const std::string& path, const TrajectoryHeader& header, const TrajectoryLayout& layout);
  // Continues a file written with the same layout after its first keep_rows rows (a resumed run):
  // the rows after them are invalidated before the constructor returns, and appends follow.
  TrajectoryWriter(const std::string& path, const TrajectoryLayout& layout, int keep_rows);
  ~TrajectoryWriter();
  TrajectoryWriter(const TrajectoryWriter&) = delete;
  TrajectoryWriter& operator=(const TrajectoryWriter&) = delete;

  // Appends one step to every element and flushes the file. Refuses (TrajectoryError) non-finite
  // values: a diverged state is never written.
  void append(const TrajectoryStep& step);
  int steps_written() const { return m_steps; }
  // Rows currently allocated in every dataset (>= steps_written() until close()).
  int rows_allocated() const { return m_impl ? m_capacity : m_steps; }
  const std::string& path() const { return m_path; }
  const TrajectoryLayout& layout() const { return m_layout; }
  // The open HDF5 file (hid_t), for the checkpoint kept in the same file (io/checkpoint.hpp).
  long long file_id() const;
  void close();

 private:
  struct Impl;
  void resize_all(unsigned long long rows);

  std::string m_path;
  TrajectoryLayout m_layout;
  int m_steps = 0;
  int m_capacity = 0;
  std::unique_ptr<Impl> m_impl;
};

// Everything a reader needs from a trajectory (tests, `fascia info`).
struct ParticleGroupInfo {
  std::string name;
  int count = 0;  // particles
};

class TrajectoryReader {
 public:
  explicit TrajectoryReader(const std::string& path);
  ~TrajectoryReader();
  TrajectoryReader(const TrajectoryReader&) = delete;
  TrajectoryReader& operator=(const TrajectoryReader&) = delete;

  // Complete steps: the shortest step dataset of all elements.
  int step_count() const { return m_steps; }
  std::vector<int> steps() const;
  std::vector<double> times() const;
  std::vector<ParticleGroupInfo> particle_groups() const;
  // Time series under /particles/<group> (position, orientation and the per-particle fields).
  std::vector<std::string> particle_elements(const std::string& group) const;
  std::vector<std::string> observable_names() const;
  // Observable values over the complete steps.
  std::vector<double> observable(const std::string& name) const;
  // Whether the observable is stored as integers (counts, flags: the layout's is_integer).
  bool observable_is_integer(const std::string& name) const;
  // value[k] of /particles/<group>/<element>, flattened ([N][3] or [N][4]).
  std::vector<double> particle_values(const std::string& group, const std::string& element, int k) const;
  // /connectivity/<surface> flattened, with its nodes per face.
  std::vector<int> connectivity(const std::string& surface, int& nodes_per_face) const;
  // A text dataset under /parameters ("" when absent; io/hdf5_text.hpp).
  std::string parameter(const std::string& name) const;
  // /h5md attributes.
  std::vector<int> h5md_version() const;
  std::string creator_name() const;
  std::string creator_version() const;

 private:
  std::string creator_attribute(const std::string& name) const;
  struct Impl;
  std::unique_ptr<Impl> m_impl;
  int m_steps = 0;
};

}  // namespace fascia
