// Checkpoints in the trajectory file: round trip, the resume of a trajectory after its kept rows,
// and atomicity under SIGKILL at arbitrary instants of a checkpoint write.
#include "io/checkpoint.hpp"
#include "solve/diagonal_shifts.hpp"
#include "io/trajectory.hpp"

#include <catch2/catch.hpp>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <random>
#include <thread>

using namespace fascia;
namespace fs = std::filesystem;

namespace {

constexpr int kFrames = 400;  // large enough that a slot write takes a measurable time

TrajectoryLayout frames_layout() {
  TrajectoryLayout layout;
  layout.frames = kFrames;
  layout.fields = {{"frames", "velocity", 3, "m/s"}, {"frames", "angular_velocity", 3, "rad/s"}};
  layout.observables = {{"elastic_energy", false}};
  layout.capacity = 4;
  return layout;
}

// A state whose every value is a function of `sequence`, so that a slot can be checked whole.
Checkpoint checkpoint_for(long long sequence) {
  Checkpoint c;
  c.step = static_cast<int>(3 * sequence);
  c.time = 0.01 * static_cast<double>(c.step);
  c.dt = 0.01;
  c.rows = static_cast<int>(sequence);
  c.finished = sequence % 5 == 0;
  for (int i = 0; i < 3 * kFrames; ++i) c.state.positions.push_back(static_cast<double>(sequence) + 1e-3 * i);
  for (int i = 0; i < kFrames; ++i) c.state.orientations.insert(c.state.orientations.end(), {1, 0, 0, 1e-6 * sequence});
  for (int i = 0; i < 6 * kFrames; ++i) c.state.velocities.push_back(-static_cast<double>(sequence) - 1e-3 * i);
  c.controller = StepControllerState{0.002 * static_cast<double>(sequence), sequence % 3 == 0, 10 * sequence,
                                     sequence + 1};
  c.progress = AdvanceProgress{7 * sequence, 31 * sequence, sequence, 2 * sequence};
  // Every other checkpoint holds a reused factorisation's origin (two states apart from c.state).
  c.tangent.held = sequence % 2 == 1;
  c.tangent.shift_step = static_cast<int>(sequence % 4) - 1;  // kept whether a factorisation is held or not
  if (c.tangent.held) {
    c.tangent.pattern = 0xfedcba9876543210ull + static_cast<std::uint64_t>(sequence);  // all 64 bits kept
    c.tangent.origin.dt = 0.005 * static_cast<double>(sequence);
    c.tangent.origin.load_scale = 1.0 / static_cast<double>(sequence + 1);
    c.tangent.origin.start = c.state;
    c.tangent.origin.state = c.state;
    for (double& x : c.tangent.origin.start.positions) x += 0.25;
    for (double& v : c.tangent.origin.state.velocities) v *= 3;
  }
  // Every third holds a static path history (the previous equilibrium and the step from it).
  if (sequence % 3 == 1) {
    c.history.dt = 0.0025 * static_cast<double>(sequence);
    c.history.previous = c.state;
    for (double& x : c.history.previous.positions) x -= 0.125;
  }
  return c;
}

void check_is(const Checkpoint& read, long long sequence) {
  const Checkpoint expected = checkpoint_for(sequence);
  CHECK(read.sequence == sequence);
  CHECK(read.step == expected.step);
  CHECK(read.time == expected.time);
  CHECK(read.dt == expected.dt);
  CHECK(read.rows == expected.rows);
  CHECK(read.finished == expected.finished);
  CHECK(read.state.positions == expected.state.positions);  // bitwise
  CHECK(read.state.orientations == expected.state.orientations);
  CHECK(read.state.velocities == expected.state.velocities);
  CHECK(read.controller.dt == expected.controller.dt);
  CHECK(read.controller.after_rejection == expected.controller.after_rejection);
  CHECK(read.controller.accepted == expected.controller.accepted);
  CHECK(read.controller.rejected == expected.controller.rejected);
  CHECK(read.progress.newton_iterations == expected.progress.newton_iterations);
  CHECK(read.progress.cg_iterations == expected.progress.cg_iterations);
  CHECK(read.progress.accepted == expected.progress.accepted);
  CHECK(read.progress.rejected == expected.progress.rejected);
  CHECK(read.history.held() == expected.history.held());
  CHECK(read.history.dt == expected.history.dt);
  CHECK(read.history.previous.positions == expected.history.previous.positions);
  CHECK(read.history.previous.orientations == expected.history.previous.orientations);
  CHECK(read.history.previous.velocities == expected.history.previous.velocities);
  CHECK(read.tangent.held == expected.tangent.held);
  CHECK(read.tangent.pattern == expected.tangent.pattern);
  CHECK(read.tangent.shift_step == expected.tangent.shift_step);
  CHECK(read.tangent.origin.dt == expected.tangent.origin.dt);
  CHECK(read.tangent.origin.load_scale == expected.tangent.origin.load_scale);
  for (const auto& [a, b] : {std::pair{&read.tangent.origin.start, &expected.tangent.origin.start},
                             std::pair{&read.tangent.origin.state, &expected.tangent.origin.state}}) {
    CHECK(a->positions == b->positions);  // bitwise
    CHECK(a->orientations == b->orientations);
    CHECK(a->velocities == b->velocities);
  }
}

struct FrameData {
  std::vector<double> x, q, v, w;
};

FrameData frame_data(int k) {
  FrameData d;
  for (int i = 0; i < 3 * kFrames; ++i) {
    d.x.push_back(k + 1e-3 * i);
    d.v.push_back(-k);
    d.w.push_back(0.5 * k);
  }
  for (int i = 0; i < kFrames; ++i) d.q.insert(d.q.end(), {1, 0, 0, 0});
  return d;
}

void append_step(TrajectoryWriter& writer, int k) {
  const FrameData d = frame_data(k);
  TrajectoryStep s;
  s.step = k;
  s.time = 0.01 * k;
  s.frame_positions = d.x.data();
  s.frame_orientations = d.q.data();
  s.fields = {d.v.data(), d.w.data()};
  s.observables = {static_cast<double>(k)};
  writer.append(s);
}

fs::path new_file(const std::string& name) {
  const fs::path path = fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()) + ".h5");
  TrajectoryWriter writer(path.string(), TrajectoryHeader{}, frames_layout());
  CheckpointWriter::create(writer.file_id(), path.string(), kFrames, {"scene text", "build text"});
  append_step(writer, 0);
  return path;
}

}  // namespace

TEST_CASE("checkpoints round-trip and the last committed one is read", "[io][checkpoint]") {
  const fs::path path = new_file("fascia_test_checkpoint");
  CHECK_FALSE(read_checkpoint(path.string()).has_value());  // created, nothing committed
  {
    TrajectoryWriter writer(path.string(), frames_layout(), 1);
    CheckpointWriter checkpoints = CheckpointWriter::open(writer.file_id(), path.string());
    for (long long s = 1; s <= 3; ++s) checkpoints.write(checkpoint_for(s));
    CHECK(checkpoints.sequence() == 3);
  }
  CheckpointIdentity identity;
  const std::optional<Checkpoint> c = read_checkpoint(path.string(), &identity);
  REQUIRE(c.has_value());
  check_is(*c, 3);
  CHECK(identity.scene == "scene text");
  CHECK(identity.build == "build text");
  // A writer reopened later continues the sequence (slot 0 next, not the committed slot 1).
  {
    TrajectoryWriter writer(path.string(), frames_layout(), 1);
    CheckpointWriter checkpoints = CheckpointWriter::open(writer.file_id(), path.string());
    CHECK(checkpoints.sequence() == 3);
    checkpoints.write(checkpoint_for(4));
  }
  check_is(*read_checkpoint(path.string()), 4);
  // A shift step outside the shifts is refused as corrupt.
  {
    TrajectoryWriter writer(path.string(), frames_layout(), 1);
    CheckpointWriter checkpoints = CheckpointWriter::open(writer.file_id(), path.string());
    Checkpoint bad = checkpoint_for(5);
    bad.tangent.shift_step = kShiftSteps;
    checkpoints.write(bad);
  }
  CHECK_THROWS_WITH(read_checkpoint(path.string()), Catch::Contains("tangent shift step 10 (corrupt)"));
  fs::remove(path);
}

TEST_CASE("a resumed trajectory drops the rows after the kept ones", "[io][checkpoint]") {
  const fs::path path = new_file("fascia_test_keep_rows");
  {
    TrajectoryWriter writer(path.string(), frames_layout(), 1);
    for (int k = 1; k <= 5; ++k) append_step(writer, k);  // 6 rows, capacity doubled once
  }
  CHECK(TrajectoryReader(path.string()).step_count() == 6);
  {
    TrajectoryWriter writer(path.string(), frames_layout(), 3);  // keep steps 0, 1, 2
    CHECK(writer.steps_written() == 3);
    // Before anything new is written, the dropped rows no longer read as complete.
    CHECK(TrajectoryReader(path.string()).step_count() == 3);
    append_step(writer, 3);
    CHECK(TrajectoryReader(path.string()).step_count() == 4);
  }
  const TrajectoryReader reader(path.string());
  CHECK(reader.steps() == std::vector<int>{0, 1, 2, 3});
  CHECK(reader.particle_values("frames", "velocity", 3) == frame_data(3).v);
  CHECK(reader.particle_values("frames", "angular_velocity", 2) == frame_data(2).w);
  CHECK_THROWS_AS(TrajectoryWriter(path.string(), frames_layout(), 5), TrajectoryError);  // more than it has
  fs::remove(path);
}

TEST_CASE("a checkpoint write killed at any instant leaves the previous or the new checkpoint", "[io][checkpoint]") {
  const fs::path path = new_file("fascia_test_checkpoint_kill");
  // How long one checkpoint takes here (two flushes and fsyncs): kills are spread over it.
  double seconds_per_write = 0;
  {
    TrajectoryWriter writer(path.string(), frames_layout(), 1);
    CheckpointWriter checkpoints = CheckpointWriter::open(writer.file_id(), path.string());
    const auto t0 = std::chrono::steady_clock::now();
    for (long long s = 1; s <= 5; ++s) checkpoints.write(checkpoint_for(s));
    seconds_per_write = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / 5;
  }
  std::mt19937 random(12345);
  long long committed = 5;
  int interrupted = 0;
  for (int attempt = 0; attempt < 24; ++attempt) {
    int ready[2];
    REQUIRE(::pipe(ready) == 0);
    const pid_t child = ::fork();
    REQUIRE(child >= 0);
    if (child == 0) {
      // The child opens the file, says so, then writes checkpoints until it is killed.
      ::close(ready[0]);
      try {
        TrajectoryWriter writer(path.string(), frames_layout(), 1);
        CheckpointWriter checkpoints = CheckpointWriter::open(writer.file_id(), path.string());
        const char byte = 1;
        if (::write(ready[1], &byte, 1) != 1) ::_exit(4);
        for (;;) checkpoints.write(checkpoint_for(checkpoints.sequence() + 1));
      } catch (...) {
        ::_exit(3);
      }
    }
    ::close(ready[1]);
    char byte = 0;
    REQUIRE(::read(ready[0], &byte, 1) == 1);
    ::close(ready[0]);
    // Kill at a random instant within the next few writes.
    std::uniform_real_distribution<double> delay(0.0, 3.0 * seconds_per_write);
    std::this_thread::sleep_for(std::chrono::duration<double>(delay(random)));
    ::kill(child, SIGKILL);
    int status = 0;
    ::waitpid(child, &status, 0);
    REQUIRE(WIFSIGNALED(status));  // the child never stopped on its own (an error would exit 3)
    const std::optional<Checkpoint> c = read_checkpoint(path.string());
    REQUIRE(c.has_value());
    CHECK(c->sequence >= committed);  // never an older one than was committed before
    check_is(*c, c->sequence);        // and whole
    if (c->sequence > committed) ++interrupted;
    committed = c->sequence;
  }
  // Some children must have committed before being killed, or the kills all fell before the
  // first write and the test showed nothing.
  INFO("children that committed at least one checkpoint before the kill: " << interrupted);
  CHECK(interrupted > 0);
  fs::remove(path);
}
