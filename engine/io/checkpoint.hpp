// Checkpoints: everything a run needs to continue exactly, kept in its trajectory file.
//
//   /checkpoint                   attributes format (int), frames (int); datasets scene, build
//                                 (text: what the run's identity was when the file was created)
//   /checkpoint/slot_0, slot_1    counters int64 [4]: sequence, step, rows, finished;
//                                 clock float64 [2]: time, dt (s);
//                                 positions [N][3], orientations [N][4], velocities [N][6];
//                                 tangent int64 [5]: held, pattern fingerprint (bits of a uint64),
//                                 the held factorisation's solves and CG iterations, and the
//                                 last factorisation's shift step (-1: none);
//                                 tangent_clock float64 [2]: dt (s), load factor;
//                                 tangent_start_{positions,orientations,velocities},
//                                 tangent_{positions,orientations,velocities} as the state
//                                 (integrate/tangent_origin.hpp; zeros where not held);
//                                 controller float64 [2]: dt (s), after_rejection (0 or 1);
//                                 controller_counts int64 [6]: accepted, rejected, and the
//                                 advance in progress: Newton and CG iterations, accepted,
//                                 rejected (solve/step_controller.hpp; zeros unless adaptive);
//                                 history float64 [1]: the step h_old (s) from the previous
//                                 state (static steps: equilibrium) to the state, 0 when none
//                                 is held;
//                                 history_{positions,orientations,velocities}: that previous
//                                 state (integrate/step_predictor.hpp; zeros where not held)
//   /checkpoint/commit            int64 [2]: the committed sequence number (0: none yet) and its step
//
// Atomicity: every dataset is contiguous and allocated when the file is created, so writing a
// checkpoint changes raw data only, never HDF5 metadata. A checkpoint with sequence number s goes
// to slot s % 2 (the slot not committed), is flushed and synced to disk, and only then is the
// 16-byte commit record written, flushed and synced. A process killed at any instant leaves the
// commit record pointing at a complete slot: the new checkpoint or the one before.
//
// format 4 holds what the integrators carry from step to step: the frames' state, the step count
// and the time (Simulation::restore), the step size dt, the origin of the factorisation PCG
// reuses (Simulation::restore_tangent), an adaptive run's step controller and the attempts
// since its last output time (StepController::restore, Simulation::restore_progress), and the
// previous state the steps' starting guesses extrapolate from (Simulation::restore_path_history).
// A format that adds datasets to the slots raises `format`; a reader reads its own format only (a
// checkpoint is resumed by the build that wrote it).
#pragma once

#include "integrate/step_error.hpp"
#include "integrate/step_predictor.hpp"
#include "integrate/tangent_origin.hpp"
#include "model/state.hpp"

#include <optional>
#include <string>

namespace fascia {

constexpr int kCheckpointFormat = 6;

struct Checkpoint {
  long long sequence = 0;  // 1, 2, ... in the order written
  int step = 0;            // completed steps
  double time = 0;         // s, after `step`
  double dt = 0;           // s, the step size of the next step
  int rows = 0;            // trajectory rows that belong to the run up to `step` (a resume keeps these)
  bool finished = false;   // the run had completed every step
  State state;             // frames: positions, orientations, velocities
  ReusedTangent tangent;    // PCG's reused factorisation (Simulation::reused_tangent())
  StepControllerState controller;  // adaptive steps: the controller (Simulation::controller())
  AdvanceProgress progress;        // adaptive steps: since the last output time
  PathHistory history;             // the predictor's previous state (Simulation::path_history())
};

// What a checkpoint may be resumed by: the resolved scene and the build that wrote it.
struct CheckpointIdentity {
  std::string scene;
  std::string build;
};

class CheckpointWriter {
 public:
  // Creates /checkpoint, both slots and an empty commit record in an open HDF5 file
  // (TrajectoryWriter::file_id(); the caller flushes with its first step).
  static CheckpointWriter create(long long file_id, const std::string& path, int frames,
                                 const CheckpointIdentity& identity);
  // Continues the checkpoints of an existing file (a resumed run).
  static CheckpointWriter open(long long file_id, const std::string& path);

  // Writes `checkpoint` with the next sequence number (its own is ignored) and commits it.
  // Throws TrajectoryError on HDF5 or disk failure.
  void write(const Checkpoint& checkpoint);
  long long sequence() const { return m_sequence; }

 private:
  CheckpointWriter(long long file_id, std::string path, int frames, long long sequence)
      : m_file(file_id), m_path(std::move(path)), m_frames(frames), m_sequence(sequence) {}
  long long m_file;
  std::string m_path;
  int m_frames;
  long long m_sequence;
};

// The committed checkpoint of a trajectory file, nullopt when none was committed (or the file
// has no /checkpoint). identity, when given, receives the stored scene and build. Throws
// TrajectoryError when the file cannot be read or holds an inconsistent or newer checkpoint.
std::optional<Checkpoint> read_checkpoint(const std::string& path, CheckpointIdentity* identity = nullptr);

}  // namespace fascia
