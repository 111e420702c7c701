// fascia run SCENE: simulate a scene and write its trajectory (HDF5, H5MD layout) and XDMF sidecar.
//
// Robustness contract (DESIGN.md, docs/hpc.md): every written step is flushed, so a run killed at
// any moment leaves a readable file; a checkpoint (io/checkpoint.hpp) is committed after the
// initial state, at the scene's cadence, on a stop and at the end, so a run can continue with
// --resume; a stop signal or --max-wall (stop_signals.hpp) abandons the step in progress, writes
// the last completed step and a checkpoint and exits 75; a solver failure keeps the completed
// steps and exits 1; non-finite states are never written; an existing output is never replaced
// without --overwrite, and an input never (run_files.hpp). --backend cuda without a usable device
// exits 69 before anything is read or written.
#include "backend.hpp"
#include "commands.hpp"
#include "number_checks.hpp"
#include "output_check.hpp"
#include "output_thread.hpp"
#include "process_threads.hpp"
#include "progress.hpp"
#include "run_files.hpp"
#include "run_identity.hpp"
#include "run_scene.hpp"
#include "scene_report.hpp"
#include "stop_signals.hpp"

#include "core/stop_request.hpp"
#include "io/checkpoint.hpp"
#include "io/sample_fields.hpp"
#include "io/trajectory.hpp"
#include "io/vertex_fields.hpp"
#include "io/xdmf.hpp"
#include "mechanics/external_loads.hpp"
#include "mechanics/frame_sample.hpp"

#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <iostream>
#include <memory>

namespace fascia::app {

namespace {

namespace fs = std::filesystem;

std::string shell_quote(const std::string& s) {
  if (!s.empty() && s.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-./=:,+@") ==
                        std::string::npos)
    return s;
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// The command line as typed (Linux: /proc/self/cmdline), shell-quoted, for /parameters.
std::string command_line() {
  std::ifstream in("/proc/self/cmdline", std::ios::binary);
  std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::string out, word;
  for (char c : all) {
    if (c == '\0') {
      out += (out.empty() ? "" : " ") + shell_quote(word);
      word.clear();
    } else {
      word += c;
    }
  }
  return out;
}

std::string env(const char* name) {
  const char* v = std::getenv(name);
  return v ? v : "";
}

// Where and how the run was computed: host, user, start time, threads, job ids, and the backend
// of the volumetric elasticity ("backend"; with cuda also "gpu" and "precision").
std::string environment_json(int threads, const nlohmann::json& backend) {
  nlohmann::json e;
  char host[256] = {0};
  gethostname(host, sizeof host - 1);
  e["host"] = host;
  e["user"] = env("USER");
  std::error_code ec;
  e["cwd"] = fs::current_path(ec).string();
  const std::time_t now = std::time(nullptr);
  char stamp[64];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  e["started"] = stamp;
  e["threads"] = threads;
  for (const auto& [key, value] : backend.items()) e[key] = value;
  for (const char* key : {"SLURM_JOB_ID", "SLURM_ARRAY_JOB_ID", "SLURM_ARRAY_TASK_ID", "SLURM_JOB_NAME",
                          "SLURM_CLUSTER_NAME", "PBS_JOBID", "LSB_JOBID", "OMP_NUM_THREADS"})
    if (!env(key).empty()) e[key] = env(key);
  return e.dump();
}

const std::vector<std::pair<std::string, bool>>& observable_layout() {
  static const std::vector<std::pair<std::string, bool>> layout = {
      {"elastic_energy", false},    {"kinetic_energy", false}, {"external_potential", false},
      {"total_energy", false},      {"newton_iterations", true}, {"cg_iterations", true},
      {"residual", false},          {"converged", true},         {"wall_time", false},
      {"dt", false},                {"accepted_steps", true},    {"rejected_steps", true},
  };
  return layout;
}

// Everything one output step needs, computed from the simulation state.
class StepRecorder {
 public:
  // device: where the sample fields are computed (null: here, sample_fields).
  StepRecorder(const dsl::BuiltScene& built, bool samples, SampleFieldsDevice* device)
      : m_built(built), m_samples(samples), m_device(device) {
    // Shells are in model.shells in the order of the shell objects.
    int shell = 0;
    for (const dsl::BuiltObject& o : built.objects) {
      const Shell* object_shell = nullptr;
      for (const ObjectInfo& info : built.model.objects) {
        if (info.kind == ObjectKind::shell && info.name == o.name)
          object_shell = &built.model.shells[static_cast<std::size_t>(shell)];
      }
      SurfaceSource source;
      if (object_shell) {
        source = shell_surface_source(built.model, o.surface, *object_shell);
        ++shell;
      }
      source.surface = &o.surface;
      if (o.skinned) source.skin = &o.skin;
      m_sources.push_back(std::move(source));
    }
    m_averaged.assign(static_cast<std::size_t>(built.model.frame_count()), 0);
    for (const SurfaceSource& source : m_sources) mark_surface_frames(source, m_averaged);
  }

  TrajectoryLayout layout() {
    TrajectoryLayout layout;
    layout.frames = m_built.model.frame_count();
    layout.samples = m_samples ? m_built.model.sample_count() : 0;
    for (const dsl::BuiltObject& o : m_built.objects) layout.surfaces.push_back(o.surface);
    layout.observables = observable_layout();
    // The fields' names, sizes and units, from an evaluation at rest.
    compute_fields(rest_state(m_built.model));
    for (const auto& [group, field] : m_fields)
      layout.fields.push_back(FieldLayout{group, field->name, field->components, field->unit, field->single});
    return layout;
  }

  TrajectoryStep record(const State& state, const StepReport& report) {
    TrajectoryStep step;
    step.step = report.step;
    step.time = report.time;
    step.frame_positions = state.positions.data();
    step.frame_orientations = state.orientations.data();
    compute_fields(state);  // the rotations, the fields and the samples' positions
    if (m_samples) step.sample_positions = m_sample_positions.data();
    // Mesh-based objects: surface vertices are frames. Meshless objects: surface vertices are
    // carried by the frames like samples, eq. (3), with their own weights.
    m_surfaces.resize(m_built.objects.size());
    for (std::size_t o = 0; o < m_built.objects.size(); ++o) {
      const dsl::BuiltObject& object = m_built.objects[o];
      const std::vector<int>& frames = object.surface.vertex_frames;
      std::vector<double>& out = m_surfaces[o];
      out.resize(3 * frames.size());
      if (object.skinned) {
        const NeighbourTable& t = object.skin;
        const PairTableView view{t.offsets.data(), t.frames.data(), t.weights.data(), t.weight_gradients.data(),
                                 t.rest_offsets.data()};
#pragma omp parallel for schedule(static)
        for (std::size_t v = 0; v < frames.size(); ++v) {
          const Vec3 p = sample_position(view, static_cast<int>(v), state.positions.data(), m_field_rotations.data());
          out[3 * v] = p.x;
          out[3 * v + 1] = p.y;
          out[3 * v + 2] = p.z;
        }
      } else {
        for (std::size_t v = 0; v < frames.size(); ++v)
          for (std::size_t k = 0; k < 3; ++k)
            out[3 * v + k] = state.positions[3 * static_cast<std::size_t>(frames[v]) + k];
      }
      step.surface_positions.push_back(out.data());
    }
    for (const auto& entry : m_fields) step.fields.push_back(entry.second->values.data());
    step.observables = {report.elastic_energy,
                        report.kinetic_energy,
                        report.external_potential,
                        report.elastic_energy + report.kinetic_energy + report.external_potential,
                        static_cast<double>(report.newton_iterations),
                        static_cast<double>(report.cg_iterations),
                        report.residual,
                        report.converged ? 1.0 : 0.0,
                        report.wall_seconds,
                        report.dt,
                        static_cast<double>(report.accepted_steps),
                        static_cast<double>(report.rejected_steps)};
    return step;
  }

 private:
  // Per-particle fields of frames, samples (when written) and surfaces (sample_fields.hpp,
  // vertex_fields.hpp), listed in m_fields as (group, field).
  void compute_fields(const State& state) {
    const Model& model = m_built.model;
    rotation_matrices(state, m_field_rotations);
    m_frame_fields = frame_fields(model, state, m_field_rotations);
    std::vector<double>* positions = m_samples ? &m_sample_positions : nullptr;
    if (m_device)
      m_device->compute(state, m_field_rotations, m_sample_fields, positions);
    else
      sample_fields(model, state, m_field_rotations, m_sample_fields, positions);
    const std::vector<Field> averages =
        m_device ? m_device->frame_averages(&m_averaged) : frame_averages(model, m_sample_fields, &m_averaged);
    m_surface_fields.clear();
    for (const SurfaceSource& source : m_sources)
      m_surface_fields.push_back(surface_fields(model, state, m_field_rotations, source, averages));
    m_fields.clear();
    for (const Field& f : m_frame_fields) m_fields.emplace_back("frames", &f);
    if (m_samples)
      for (const Field& f : m_sample_fields) m_fields.emplace_back("samples", &f);
    for (std::size_t o = 0; o < m_sources.size(); ++o)
      for (const Field& f : m_surface_fields[o]) m_fields.emplace_back(m_sources[o].surface->name, &f);
  }

  const dsl::BuiltScene& m_built;
  bool m_samples;
  SampleFieldsDevice* m_device;
  std::vector<SurfaceSource> m_sources;
  std::vector<unsigned char> m_averaged;  // [N] the frames whose sample averages a surface shows
  std::vector<double> m_field_rotations;
  std::vector<Field> m_frame_fields, m_sample_fields;
  std::vector<std::vector<Field>> m_surface_fields;
  std::vector<std::pair<std::string, const Field*>> m_fields;
  std::vector<double> m_sample_positions;
  std::vector<std::vector<double>> m_surfaces;
};

bool finite_state(const State& state) {
  for (double v : state.positions)
    if (!std::isfinite(v)) return false;
  for (double v : state.orientations)
    if (!std::isfinite(v)) return false;
  for (double v : state.velocities)
    if (!std::isfinite(v)) return false;
  return true;
}

// The run's file when --resume finds it: the committed checkpoint to continue from, or a reason
// to refuse (exit code and message), or nothing (start over).
struct ResumePoint {
  std::optional<Checkpoint> checkpoint;
  std::vector<double> times;  // of the trajectory rows kept
  int code = kOk;
  std::string refusal;
};

ResumePoint resume_point(const std::string& output, const dsl::SceneSpec& spec) {
  ResumePoint point;
  CheckpointIdentity stored;
  try {
    point.checkpoint = read_checkpoint(output, &stored);
    if (!point.checkpoint) {
      // Killed before its first checkpoint was committed: at most the initial state is lost.
      const TrajectoryReader reader(output);
      if (reader.step_count() > 1) {
        point.code = kDataError;
        point.refusal = output + " holds " + std::to_string(reader.step_count()) +
                        " steps but no checkpoint to continue from; give --overwrite to start over";
      }
      return point;
    }
    const TrajectoryReader reader(output);
    point.times = reader.times();
  } catch (const TrajectoryError& e) {
    point.code = kDataError;
    point.refusal = std::string(e.what()) + "; cannot resume (give --overwrite to start over)";
    return point;
  }
  if (stored.build != build_identity()) {
    point.code = kDataError;
    point.refusal = output + ": the checkpoint was written by another build (" + stored.build + "; this is " +
                    build_identity() + "); resume with that build, or give --overwrite to start over";
  } else if (const std::string diff = first_difference(scene_identity(spec), stored.scene); !diff.empty()) {
    point.code = kDataError;
    point.refusal = output + ": the checkpoint belongs to another scene (" + diff +
                    "); resume with the same scene and --set values, or give --overwrite to start over";
  } else if (static_cast<std::size_t>(point.checkpoint->rows) > point.times.size()) {
    point.code = kDataError;
    point.refusal = output + ": the checkpoint keeps " + std::to_string(point.checkpoint->rows) +
                    " trajectory rows, the file has " + std::to_string(point.times.size());
  }
  point.times.resize(std::min(point.times.size(), static_cast<std::size_t>(point.checkpoint->rows)));
  return point;
}

}  // namespace

int run_scene(const RunOptions& options, RunFigures* run_figures) {
  const auto setup_start = std::chrono::steady_clock::now();
  // The device first: a missing GPU is reported before the scene is discretised.
  Backend backend;
  if (const int code = resolve_backend("run", options.backend, backend); code != kOk) return code;
  const ExistingOutput existing =
      options.resume ? ExistingOutput::resume : options.overwrite ? ExistingOutput::overwrite : ExistingOutput::refuse;
  // From here a stop signal is recorded; it takes effect once the run has a file to write to.
  install_stop_signals();
  const auto wall_start = std::chrono::steady_clock::now();
  if (options.max_wall) arm_max_wall(*options.max_wall);

  // The output and its sidecars are refused (an existing file without --overwrite or --resume, an
  // input of the run) once the scene is parsed, before it is discretised.
  const auto refuse_outputs = [&](const dsl::SceneSpec& spec) -> int {
    const std::string output = output_path(options.request, spec);
    std::vector<std::string> outputs{output};
    if (spec.output.xdmf) {
      outputs.push_back(xdmf_path_for(output));
      outputs.push_back(xdmf_path_for(output) + "2");  // the XDMF 2 sidecar (io/xdmf.hpp)
    }
    const std::string refusal = output_refusal(outputs, run_inputs(spec), existing);
    if (refusal.empty()) return 0;
    std::cerr << "fascia: error: " << refusal << "\n";
    return kCantCreate;
  };
  int code = 0;
  std::unique_ptr<LoadedScene> scene = load_scene(options.request, code, refuse_outputs);
  if (!scene) return code;
  dsl::BuiltScene& built = scene->built;
  built.settings.elasticity = backend.elasticity;
  built.settings.step_backend = backend.step;
  if (options.threads >= 0) built.settings.threads = options.threads;
  // A step on the device leaves every host thread to its rows; a CPU step takes as many as the
  // scene's size can use, and its rows the rest.
  if (!backend.step) {
    const bool row_per_step = built.settings.integrator != Integrator::static_equilibrium &&
                              !built.settings.adaptive.enabled && scene->spec.output.every == 1;
    built.settings.threads = step_threads(built.model, built.settings.threads, process_threads(), row_per_step);
  }
  bound_process_threads(built.settings.threads);
  // The device's memory is estimated before anything is put there or written.
  if (backend.memory_refusal) {
    const std::string refusal = backend.memory_refusal(built.model, built.settings);
    if (!refusal.empty()) {
      std::cerr << "fascia: error: " << options.request.path << ": --backend cuda: " << refusal << "\n";
      return kTooLarge;
    }
  }

  // The steps of this run: the scene's, or fewer under a benchmark's cap.
  const int steps = options.max_steps > 0 ? std::min(options.max_steps, built.steps) : built.steps;
  const std::string output = output_path(options.request, scene->spec);
  const dsl::OutputSpec& out_spec = scene->spec.output;
  const std::string xmf = xdmf_path_for(output);
  ResumePoint resume;
  std::error_code exists_error;
  if (options.resume && fs::exists(output, exists_error)) {
    resume = resume_point(output, scene->spec);
    if (resume.code != kOk) {
      std::cerr << "fascia: error: " << resume.refusal << "\n";
      return resume.code;
    }
  }
  const int checkpoint_every = options.checkpoint_every.value_or(out_spec.checkpoint_every);
  const double checkpoint_interval = options.checkpoint_interval.value_or(out_spec.checkpoint_interval);

  Progress progress(Progress::mode_for(options.quiet), options.status_interval);
  const bool log = !options.quiet;
  if (resume.checkpoint && resume.checkpoint->finished) {
    // A finished run asked to resume (a requeued task that had completed): nothing to do.
    std::cerr << "fascia: " << output << ": the run finished (step " << resume.checkpoint->step << ", t = "
              << resume.checkpoint->time << " s); nothing to resume\n";
    if (options.json)
      std::cout << nlohmann::json{{"scene", options.request.path}, {"output", output}, {"status", "finished"},
                                  {"exit_code", kOk}, {"steps", resume.checkpoint->step},
                                  {"steps_planned", steps}, {"time", resume.checkpoint->time}}
                       .dump()
                << "\n";
    return kOk;
  }
  if (log) {
    const dsl::DiscretisationStats& s = built.stats;
    std::cerr << "fascia: " << options.request.path << ": " << s.frames << " frames, " << s.samples << " samples, " << s.dofs
              << " dofs, " << built.steps << " steps of " << built.settings.dt << " s (" << to_string(built.settings.integrator)
              << "), backend " << backend.description << " -> " << output << "\n";
    if (resume.checkpoint)
      std::cerr << "fascia: resuming from the checkpoint at step " << resume.checkpoint->step << " (t = "
                << resume.checkpoint->time << " s)\n";
  }

  Simulation simulation(built.model, built.loads, built.settings, built.motions);
  if (log && backend.step) {
    if (simulation.on_step_backend())
      std::cerr << "fascia: the whole step runs on the device\n";
    else
      std::cerr << "fascia: the step runs on the CPU with the volumetric elasticity on the device: "
                << simulation.step_backend_refusal() << "\n";
  }
  // The sample fields on the device with --backend cuda (one for both recorders: rows are formed
  // on one thread).
  std::unique_ptr<SampleFieldsDevice> device_fields;
  if (backend.sample_fields && built.model.sample_count() > 0) device_fields = backend.sample_fields(built.model);
  // Two recorders, used in turn: a row is formed in one while the previous one's is written.
  std::array<StepRecorder, 2> recorders{StepRecorder(built, out_spec.samples, device_fields.get()),
                                        StepRecorder(built, out_spec.samples, device_fields.get())};
  TrajectoryLayout layout = recorders[0].layout();
  // Rows to preallocate: the initial state, every output step, and one written on a stop. All
  // of them up front: growing datasets later is the one write a kill could corrupt.
  // Fixed steps: the loop runs over the steps, a row every output.every steps. Adaptive steps:
  // it runs over the rows' times k dt (k a multiple of output.every, and the last step), and the
  // simulation advances to each with steps of its own; a resumed run starts at the first row
  // time after the checkpoint's (which may lie between two rows).
  const bool adaptive = simulation.controller() != nullptr;
  auto next_k = [&](int k) { return adaptive && k < steps ? std::min(k + out_spec.every, steps) : k + 1; };
  int first_k = resume.checkpoint ? resume.checkpoint->step + 1 : 1;
  if (adaptive) {
    first_k = std::min(out_spec.every, steps);
    while (resume.checkpoint && first_k < steps && first_k * built.settings.dt <= resume.checkpoint->time)
      first_k = next_k(first_k);
  }
  int rows_to_come = steps / out_spec.every - (first_k - 1) / out_spec.every + 1;
  if (adaptive) {
    rows_to_come = 0;
    for (int k = first_k; k <= steps; k = next_k(k)) ++rows_to_come;
  }
  layout.capacity = (resume.checkpoint ? resume.checkpoint->rows : 1) + rows_to_come + 1;

  std::unique_ptr<TrajectoryWriter> writer;
  std::optional<CheckpointWriter> checkpoints;
  const std::string h5_name = fs::path(output).filename().string();
  std::vector<double> written_times = resume.times;
  auto last_xdmf = std::chrono::steady_clock::now();
  double xdmf_seconds = 0;  // how long the last rewrite took
  // The sidecars are written with the first row, then after a flushed row at most once every
  // max(0.5 s, 20 x the last rewrite's duration), and at the end of the run (completed, stopped or
  // failed): they always describe complete steps only. Their text grows with the steps (about
  // 15 kB per step for the main job's objects and fields), so the interval grows with it and
  // rewriting stays below 5 % of the run. A run killed outright has every row in its .h5 file,
  // the last half second's possibly not yet in the sidecars; --resume rewrites them.
  auto update_xdmf = [&](bool force) {
    if (!out_spec.xdmf) return;
    const auto now = std::chrono::steady_clock::now();
    if (!force && std::chrono::duration<double>(now - last_xdmf).count() < std::max(0.5, 20 * xdmf_seconds)) return;
    write_xdmf(xmf, h5_name, layout, written_times,
               writer ? static_cast<std::size_t>(writer->rows_allocated()) : written_times.size());
    last_xdmf = std::chrono::steady_clock::now();
    xdmf_seconds = std::chrono::duration<double>(last_xdmf - now).count();
  };

  // Rows, checkpoints and sidecars: on threads of their own while the next steps run, where the
  // step leaves cores to them: the device's step (the host's threads are idle during it but this
  // one, which waits for the device spinning on its core, CUDA's default), or a CPU step on fewer
  // threads than the process may use (the output's parallel loops get the rest). Otherwise the
  // step's threads are all busy, and the output runs in turn with the steps.
  //
  // The output thread forms the rows (their fields, in parallel) and hands them to the writer
  // thread, which makes every HDF5 call after the file is opened here: jobs in order, so a file's
  // writes keep the order a killed run's readability relies on (io/trajectory.cpp,
  // io/checkpoint.hpp), and HDF5 is entered from one thread only. A row is written while the next
  // is formed in the other recorder: the writer holds one job at most, so a recorder is reused
  // only after its row is written. The output thread holds four: a row of the pelvis at 56 k
  // samples (about 13 MB) takes longer than a device step that reuses its factorisation, and the
  // rows catch up during the next one that factorises; each job holds a copy of a step's state
  // (the frames', about 0.1 MB at 56 k samples).
  const int step_threads = omp_get_max_threads();
  const bool spare_cores = !simulation.on_step_backend() && step_threads < process_threads();
  // The output and writer threads' OpenMP teams (the writer rounds and checks a row's values in
  // parallel before it writes them: TrajectoryWriter::append); 0: the output runs in turn with
  // the steps.
  const int output_threads = simulation.on_step_backend() ? std::max(1, step_threads - 1)
                             : spare_cores                ? process_threads() - step_threads
                                                          : 0;
  OutputThread writer_thread(output_threads > 0, output_threads, 1);
  OutputThread output_thread(output_threads > 0, output_threads, 4);
  // An HDF5 job, in order with the rows submitted before it.
  auto submit_write = [&](std::function<void()> job) {
    output_thread.submit([&writer_thread, job = std::move(job)] { writer_thread.submit(job); });
  };
  int formed_rows = 0;  // on the output thread: which recorder forms the next row
  auto submit_row = [&](const StepReport& report) {
    output_thread.submit([&, state = simulation.state(), report] {
      const TrajectoryStep row = recorders[static_cast<std::size_t>(formed_rows++ % 2)].record(state, report);
      writer_thread.submit([&, row, state, report] {
        TrajectoryStep step = row;  // its frames from this job's copy of the state
        step.frame_positions = state.positions.data();
        step.frame_orientations = state.orientations.data();
        writer->append(step);
        written_times.push_back(report.time);
        update_xdmf(false);
      });
    });
  };

  StepReport last;
  last.time = simulation.time();
  long total_newton = 0, total_cg = 0;
  ProgressFigures figures;
  figures.total = steps;
  std::string status = "completed";
  int exit_code = kOk;
  std::string failure;
  // The regular rows written so far (a row written only because of a stop is not one of them:
  // a resume drops it, and the file ends as an uninterrupted run's would).
  int regular_rows = 0;
  int checkpointed_step = -1;
  auto last_checkpoint_wall = std::chrono::steady_clock::now();
  auto write_checkpoint = [&](bool finished) {
    Checkpoint c;
    c.step = simulation.steps_taken();
    c.time = simulation.time();
    c.dt = built.settings.dt;
    c.rows = regular_rows;
    c.finished = finished;
    c.state = simulation.state();
    c.tangent = simulation.reused_tangent();
    if (const StepController* controller = simulation.controller()) c.controller = controller->state();
    c.progress = simulation.advance_progress();
    c.history = simulation.path_history();
    checkpointed_step = c.step;
    submit_write([&checkpoints, c = std::move(c)] { checkpoints->write(c); });
    last_checkpoint_wall = std::chrono::steady_clock::now();
  };
  int row_step = -1;  // the simulation step of the last row (or of the checkpoint resumed from)

  try {
    if (resume.checkpoint) {
      const Checkpoint& c = *resume.checkpoint;
      simulation.restore(c.state, c.step, c.time);
      simulation.restore_path_history(c.history);
      if (!simulation.restore_tangent(c.tangent))
        std::cerr << "fascia: warning: the preconditioner's factorisation could not be repeated exactly (its "
                     "sparsity analysis differs); the run continues correctly, to the solver's tolerances, "
                     "but may differ from an uninterrupted run in the last bits\n";
      writer = std::make_unique<TrajectoryWriter>(output, layout, c.rows);
      checkpoints = CheckpointWriter::open(writer->file_id(), output);
      regular_rows = c.rows;
      checkpointed_step = c.step;
      last.step = c.step;
      last.time = c.time;
      figures.step = c.step;
      figures.time = c.time;
      if (StepController* controller = simulation.controller()) {
        controller->restore(c.controller);
        simulation.restore_progress(c.progress);
      }
      row_step = c.step;  // the checkpoint's state is the run's; nothing to add on a stop
      update_xdmf(true);
    } else {
      TrajectoryHeader header;
      header.creator_version = FASCIA_VERSION;
      header.author = env("USER");
      header.scene = scene->spec.resolved_yaml;
      header.scene_file = options.request.path;
      header.command_line = command_line();
      header.environment = environment_json(built.settings.threads, backend.provenance);
      writer = std::make_unique<TrajectoryWriter>(output, header, layout);
      checkpoints = CheckpointWriter::create(writer->file_id(), output, built.model.frame_count(),
                                             {scene_identity(scene->spec), build_identity()});

      // Step 0: the initial configuration, and the first checkpoint.
      StepReport initial;
      initial.step = 0;
      initial.time = simulation.time();
      initial.converged = true;
      initial.kinetic_energy = kinetic_energy(simulation.model(), simulation.state());
      initial.external_potential = simulation.external_potential(simulation.state());
      submit_row(initial);
      ++regular_rows;
      write_checkpoint(steps == 0);
      row_step = 0;
      submit_write([&] { update_xdmf(true); });
    }

    const auto steps_start = std::chrono::steady_clock::now();
    if (run_figures) run_figures->setup_seconds = std::chrono::duration<double>(steps_start - setup_start).count();
    // A row sums the iterations and counts the steps since the previous one.
    StepReport row;  // the steps since the last row (fixed steps)
    // Fixed steps resumed between two rows: the steps taken since the last row (each accepted
    // once) count towards the next, as in an uninterrupted run.
    if (resume.checkpoint && !adaptive) row.accepted_steps = resume.checkpoint->step % out_spec.every;
    bool completed = steps == 0;
    for (int k = first_k; k <= steps && !stop_requested(); k = next_k(k)) {
      try {
        last = adaptive ? simulation.advance_to(k * built.settings.dt) : simulation.step();
      } catch (const StopRequested&) {
        break;  // the step in progress is abandoned; the state is the last completed step's
      } catch (const SolverError& e) {
        failure = e.what();
        status = "solver failed";
        exit_code = kSolverFailed;
        break;
      }
      if (!finite_state(simulation.state())) {
        failure = "non-finite state after step " + std::to_string(simulation.steps_taken()) + " (diverged); it was not written";
        status = "solver failed";
        exit_code = kSolverFailed;
        break;
      }
      total_newton += last.newton_iterations;
      total_cg += last.cg_iterations;
      row.accepted_steps += last.accepted_steps;
      if (adaptive || k % out_spec.every == 0 || k == steps) {
        row_step = simulation.steps_taken();
        if (!adaptive) last.accepted_steps = row.accepted_steps;
        submit_row(last);
        ++regular_rows;
        row = StepReport{};
      }
      const double since_checkpoint =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - last_checkpoint_wall).count();
      // Adaptive runs: at their rows' times, k counting multiples of dt.
      if (k == steps || take_checkpoint_request() || (checkpoint_every > 0 && k % checkpoint_every == 0) ||
          (checkpoint_interval > 0 && since_checkpoint >= checkpoint_interval))
        write_checkpoint(k == steps);
      completed = k == steps;
      if (take_hangup() && log) std::cerr << "\nfascia: SIGHUP ignored; the run goes on\n";
      figures.step = k;
      figures.time = last.time;
      figures.newton = last.newton_iterations;
      figures.cg = last.cg_iterations;
      figures.residual = last.residual;
      progress.update(figures);
    }
    if (exit_code == kOk && stop_requested() && !completed) {
      // Stopped: the last completed step is checkpointed, then written if it was not a row.
      const int done = simulation.steps_taken();
      if (checkpointed_step != done) write_checkpoint(false);
      if (row_step != done) {
        StepReport report = last;
        report.step = done;
        report.time = simulation.time();
        submit_row(report);
      }
      status = "stopped by " + stop_reason_name(stop_requested()) + " after step " + std::to_string(done) +
               " (written, checkpoint committed; continue with --resume)";
      exit_code = kStoppedOnSignal;
    }
    submit_write([&] {
      writer->close();  // shrinks the datasets to the written steps
      update_xdmf(true);
    });
    output_thread.finish();
    writer_thread.finish();
    if (run_figures)
      run_figures->step_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - steps_start).count();
  } catch (const NonFiniteStep& e) {
    // Not an I/O error: the state or its fields left the range of a double.
    std::cerr << "fascia: error: " << e.what()
              << " (diverged, or the scene's magnitudes exceed a double: moduli, densities, loads); the steps "
                 "before it are written\n";
    return kSolverFailed;
  } catch (const TrajectoryError& e) {
    std::cerr << "fascia: error: " << e.what() << "\n";
    return kIoError;
  }

  progress.finish(figures, status);
  // Logs of batch jobs must say why a run stopped, even with --quiet.
  if (options.quiet && exit_code == kStoppedOnSignal) std::cerr << "fascia: " << status << "\n";
  if (!failure.empty()) std::cerr << "fascia: error: " << failure << "\n";
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  if (options.json) {
    nlohmann::json summary = {
        {"scene", options.request.path},
        {"output", output},
        {"status", exit_code == kOk ? "ok" : exit_code == kStoppedOnSignal ? "stopped" : "solver_failed"},
        {"exit_code", exit_code},
        {"steps", simulation.steps_taken()},
        {"steps_planned", steps},
        {"steps_written", writer ? writer->steps_written() : 0},
        {"resumed_from", resume.checkpoint ? nlohmann::json(resume.checkpoint->step) : nlohmann::json(nullptr)},
        {"time", simulation.time()},
        {"newton_iterations", total_newton},
        {"cg_iterations", total_cg},
        {"accepted_steps", simulation.steps_taken()},
        {"rejected_steps", simulation.controller() ? simulation.controller()->state().rejected : 0},
        {"wall_seconds", wall},
        {"threads", {{"step", step_threads}, {"output", output_threads}}},
        {"discretisation", stats_json(built.stats)},
        {"final",
         {{"elastic_energy", last.elastic_energy},
          {"kinetic_energy", last.kinetic_energy},
          {"external_potential", last.external_potential},
          {"residual", last.residual}}}};
    for (const auto& [key, value] : backend.provenance.items()) summary[key] = value;  // backend, gpu, precision
    if (!failure.empty()) summary["message"] = failure;
    std::cout << summary.dump() << "\n";
  }
  if (run_figures) {
    run_figures->frames = built.stats.frames;
    run_figures->samples = built.stats.samples;
    run_figures->dofs = built.stats.dofs;
    run_figures->steps = simulation.steps_taken() - (resume.checkpoint ? resume.checkpoint->step : 0);
    run_figures->newton_iterations = total_newton;
    run_figures->cg_iterations = total_cg;
  }
  return exit_code;
}

namespace {

// A duration option: a quantity ("90 min", "2 h", "3600") or a Slurm time ("1:30:00").
CLI::Option* add_duration(CLI::App& command, const std::string& name, std::optional<double>& target,
                          const std::string& doc, bool zero_allowed) {
  return command
      .add_option_function<std::string>(
          name,
          [&target, name, zero_allowed](const std::string& text) {
            const std::optional<double> seconds = parse_duration(text);
            if (!seconds || (!zero_allowed && *seconds == 0))
              throw CLI::ValidationError(name, "'" + text + "' is not a duration (e.g. 90 min, 2 h, 1:30:00)");
            target = seconds;
          },
          doc)
      ->type_name("DURATION");
}

}  // namespace

void add_run_options(CLI::App& cmd, RunOptions& options) {
  add_backend_options(cmd, options.backend);
  cmd.add_option("--threads", options.threads, "CPU threads of the step (0 = one per 500 samples and shell triangles, at most the cores; one fewer, left to the rows, where that is every core of several, under 1,000 per core, with a row after each fixed dynamic step; default: the scene's solver.threads)")
      ->check(kNonNegativeNumber);
  CLI::Option* overwrite =
      cmd.add_flag("--overwrite", options.overwrite, "Replace an existing output file (refused otherwise, exit 73)");
  cmd.add_flag("--resume", options.resume,
               "Continue the run in the output file from its checkpoint (start it when there is no file)")
      ->excludes(overwrite);
  add_duration(cmd, "--max-wall", options.max_wall,
               "Stop after this wall time with a checkpoint, exit 75 (e.g. 2 h, 1:55:00)", false);
  cmd.add_option_function<int>(
         "--checkpoint-every", [&options](const int& n) { options.checkpoint_every = n; },
         "Checkpoint every n-th step (0 = off; default: output.checkpoint.every)")
      ->check(kNonNegativeNumber);
  add_duration(cmd, "--checkpoint-interval", options.checkpoint_interval,
               "Wall time between checkpoints (0 = off; default: output.checkpoint.interval)", true);
  cmd.add_flag("-q,--quiet", options.quiet, "No progress output");
  cmd.add_flag("--json", options.json, "Print a JSON summary on stdout at the end");
  cmd.add_option("--status-interval", options.status_interval,
                 "Seconds between status lines when stderr is not a terminal")
      ->check(kPositiveNumber);
}

void register_run(CLI::App& app, Action& action) {
  auto options = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand("run", "Simulate a scene and write its HDF5 trajectory (+ XDMF sidecar)");
  cmd->add_option("scene", options->request.path, "Scene file (YAML)")->required();
  cmd->add_option("-o,--output", options->request.output, "Output file (default: the scene's output.file)");
  add_scene_options(*cmd, options->request);
  add_run_options(*cmd, *options);
  cmd->callback([&action, options] { action = [options] { return run_scene(*options); }; });
}

}  // namespace fascia::app
