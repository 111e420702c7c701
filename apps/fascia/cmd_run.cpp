// fascia run SCENE: simulate a scene and write its trajectory (HDF5, H5MD layout) and XDMF sidecar.
//
// Robustness contract (DESIGN.md): every written step is flushed, so a run killed at any moment
// leaves a readable file; SIGINT/SIGTERM finish the current step, write it, close the file and
// exit 75; a solver failure keeps the completed steps and exits 1; non-finite states are never
// written. --backend cuda without a usable device exits 69 before anything is read or written.
#include "backend.hpp"
#include "commands.hpp"
#include "output_check.hpp"
#include "progress.hpp"
#include "run_scene.hpp"
#include "scene_report.hpp"

#include "io/sample_fields.hpp"
#include "io/trajectory.hpp"
#include "io/vertex_fields.hpp"
#include "io/xdmf.hpp"
#include "mechanics/external_loads.hpp"
#include "mechanics/frame_sample.hpp"

#include <unistd.h>

#include <algorithm>
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

volatile std::sig_atomic_t g_stop_signal = 0;

void on_stop_signal(int signal) { g_stop_signal = signal; }

void install_signal_handlers() {
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;  // no SA_RESTART: let blocking calls return
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

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
  StepRecorder(const dsl::BuiltScene& built, bool samples) : m_built(built), m_samples(samples) {
    // Shells are in model.shells in the order of the shell objects.
    int shell = 0;
    for (const dsl::BuiltObject& o : built.objects) {
      SurfaceSource source;
      source.surface = &o.surface;
      if (o.skinned) source.skin = &o.skin;
      for (const ObjectInfo& info : built.model.objects) {
        if (info.kind == ObjectKind::shell && info.name == o.name)
          source.shell = &built.model.shells[static_cast<std::size_t>(shell)];
      }
      if (source.shell) ++shell;
      m_sources.push_back(source);
    }
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
      layout.fields.push_back(FieldLayout{group, field->name, field->components, field->unit});
    return layout;
  }

  TrajectoryStep record(const State& state, const StepReport& report) {
    const Model& model = m_built.model;
    TrajectoryStep step;
    step.step = report.step;
    step.time = report.time;
    step.frame_positions = state.positions.data();
    step.frame_orientations = state.orientations.data();
    if (m_samples) {
      rotation_matrices(state, m_rotations);
      const PairTableView view{model.neighbours.offsets.data(), model.neighbours.frames.data(),
                               model.neighbours.weights.data(), model.neighbours.weight_gradients.data(),
                               model.neighbours.rest_offsets.data()};
      m_sample_positions.resize(3 * static_cast<std::size_t>(model.sample_count()));
      for (int s = 0; s < model.sample_count(); ++s) {
        const Vec3 p = sample_position(view, s, state.positions.data(), m_rotations.data());
        m_sample_positions[3 * static_cast<std::size_t>(s)] = p.x;
        m_sample_positions[3 * static_cast<std::size_t>(s) + 1] = p.y;
        m_sample_positions[3 * static_cast<std::size_t>(s) + 2] = p.z;
      }
      step.sample_positions = m_sample_positions.data();
    }
    // Mesh-based objects: surface vertices are frames. Meshless objects: surface vertices are
    // carried by the frames like samples, eq. (3), with their own weights.
    m_surfaces.resize(m_built.objects.size());
    for (std::size_t o = 0; o < m_built.objects.size(); ++o) {
      const dsl::BuiltObject& object = m_built.objects[o];
      const std::vector<int>& frames = object.surface.vertex_frames;
      std::vector<double>& out = m_surfaces[o];
      out.resize(3 * frames.size());
      if (object.skinned) {
        if (!m_samples) rotation_matrices(state, m_rotations);
        const NeighbourTable& t = object.skin;
        const PairTableView view{t.offsets.data(), t.frames.data(), t.weights.data(), t.weight_gradients.data(),
                                 t.rest_offsets.data()};
        for (std::size_t v = 0; v < frames.size(); ++v) {
          const Vec3 p = sample_position(view, static_cast<int>(v), state.positions.data(), m_rotations.data());
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
    compute_fields(state);
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
    m_sample_fields = sample_fields(model, state, m_field_rotations);
    const std::vector<Field> averages = frame_averages(model, m_sample_fields);
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
  std::vector<SurfaceSource> m_sources;
  std::vector<double> m_field_rotations;
  std::vector<Field> m_frame_fields, m_sample_fields;
  std::vector<std::vector<Field>> m_surface_fields;
  std::vector<std::pair<std::string, const Field*>> m_fields;
  std::vector<double> m_rotations, m_sample_positions;
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

}  // namespace

int run_scene(const RunOptions& options, RunFigures* run_figures) {
  const auto setup_start = std::chrono::steady_clock::now();
  // The device first: a missing GPU is reported before the scene is discretised.
  Backend backend;
  if (const int code = resolve_backend("run", options.backend, backend); code != kOk) return code;
  int code = 0;
  std::unique_ptr<LoadedScene> scene = load_scene(options.request, code);
  if (!scene) return code;
  dsl::BuiltScene& built = scene->built;
  built.settings.elasticity = backend.elasticity;
  built.settings.step_backend = backend.step;
  if (options.threads >= 0) built.settings.threads = options.threads;

  const std::string output = output_path(options.request, scene->spec);
  const dsl::OutputSpec& out_spec = scene->spec.output;
  Progress progress(Progress::mode_for(options.quiet), options.status_interval);
  const bool log = !options.quiet;
  if (log) {
    const dsl::DiscretisationStats& s = built.stats;
    std::cerr << "fascia: " << options.request.path << ": " << s.frames << " frames, " << s.samples << " samples, " << s.dofs
              << " dofs, " << built.steps << " steps of " << built.settings.dt << " s (" << to_string(built.settings.integrator)
              << "), backend " << backend.description << " -> " << output << "\n";
  }

  install_signal_handlers();
  const auto wall_start = std::chrono::steady_clock::now();
  const int steps = options.max_steps > 0 ? std::min(options.max_steps, built.steps) : built.steps;
  Simulation simulation(built.model, built.loads, built.settings, built.motions);
  if (log && backend.step) {
    if (simulation.on_step_backend()) {
      const LinearSettings& linear = built.settings.newton.linear;
      std::cerr << "fascia: the whole step runs on the device"
                << (linear.method == LinearMethod::pcg && linear.preconditioner != Preconditioner::block_jacobi
                        ? " (pcg preconditioned by block_jacobi: a cholmod preconditioner runs on the CPU only)"
                        : "")
                << "\n";
    }
    else
      std::cerr << "fascia: the step runs on the CPU with the volumetric elasticity on the device: "
                << simulation.step_backend_refusal() << "\n";
  }
  StepRecorder recorder(built, out_spec.samples);
  TrajectoryLayout layout = recorder.layout();
  // Rows to preallocate: the initial state, every output step, and one written on a signal. All
  // of them up front: growing datasets later is the one write a kill could corrupt.
  layout.capacity = static_cast<int>(output_rows(steps, out_spec.every));  // load_scene checked the range

  std::unique_ptr<TrajectoryWriter> writer;
  const std::string xmf = xdmf_path_for(output);
  const std::string h5_name = fs::path(output).filename().string();
  std::vector<double> written_times;
  auto last_xdmf = std::chrono::steady_clock::now();
  double xdmf_seconds = 0;  // how long the last rewrite took
  // The sidecars are rewritten after each flushed step while the run is short, then at most once
  // every max(1 s, 20 x the last rewrite's duration), and at the end: they always describe
  // complete steps only. Their text grows with the steps (about 15 kB per step for the main job's
  // objects and fields), so the interval grows with it and rewriting stays below 5 % of the run.
  auto update_xdmf = [&](bool force) {
    if (!out_spec.xdmf) return;
    const auto now = std::chrono::steady_clock::now();
    if (!force && written_times.size() > 100 &&
        std::chrono::duration<double>(now - last_xdmf).count() < std::max(1.0, 20 * xdmf_seconds))
      return;
    write_xdmf(xmf, h5_name, layout, written_times,
               writer ? static_cast<std::size_t>(writer->rows_allocated()) : written_times.size());
    last_xdmf = std::chrono::steady_clock::now();
    xdmf_seconds = std::chrono::duration<double>(last_xdmf - now).count();
  };

  StepReport last;
  last.time = simulation.time();
  long total_newton = 0, total_cg = 0;
  ProgressFigures figures;
  figures.total = steps;
  std::string status = "completed";
  int exit_code = kOk;
  std::string failure;

  try {
    TrajectoryHeader header;
    header.creator_version = FASCIA_VERSION;
    header.author = env("USER");
    header.scene = scene->spec.resolved_yaml;
    header.scene_file = options.request.path;
    header.command_line = command_line();
    header.environment = environment_json(built.settings.threads, backend.provenance);
    writer = std::make_unique<TrajectoryWriter>(output, header, layout);

    // Step 0: the initial configuration.
    StepReport initial;
    initial.step = 0;
    initial.time = simulation.time();
    initial.converged = true;
    initial.kinetic_energy = kinetic_energy(simulation.model(), simulation.state());
    initial.external_potential = load_potential(simulation.model(), simulation.loads(), simulation.state());
    writer->append(recorder.record(simulation.state(), initial));
    written_times.push_back(initial.time);
    update_xdmf(true);

    const auto steps_start = std::chrono::steady_clock::now();
    if (run_figures) run_figures->setup_seconds = std::chrono::duration<double>(steps_start - setup_start).count();
    // Fixed steps: every step, a row every output.every steps. Adaptive steps: the simulation
    // advances to each row's time (k dt, k a multiple of output.every, and the last step) with
    // steps of its own; a row sums the iterations and counts the steps since the previous one.
    const bool adaptive = simulation.controller() != nullptr;
    StepReport row;  // the steps since the last row (fixed steps)
    for (int k = adaptive ? std::min(out_spec.every, steps) : 1; k <= steps;
         k = adaptive && k < steps ? std::min(k + out_spec.every, steps) : k + 1) {
      try {
        last = adaptive ? simulation.advance_to(k * built.settings.dt) : simulation.step();
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
      const bool stop = g_stop_signal != 0;
      if (adaptive || k % out_spec.every == 0 || k == steps || stop) {
        if (!adaptive) last.accepted_steps = row.accepted_steps;
        writer->append(recorder.record(simulation.state(), last));
        written_times.push_back(last.time);
        update_xdmf(k == steps || stop);
        row = StepReport{};
      }
      figures.step = k;
      figures.time = last.time;
      figures.newton = last.newton_iterations;
      figures.cg = last.cg_iterations;
      figures.residual = last.residual;
      progress.update(figures);
      if (stop) {
        status = std::string("stopped by ") + (g_stop_signal == SIGINT ? "SIGINT" : "SIGTERM") + " after step " +
                 std::to_string(simulation.steps_taken()) + " (written)";
        exit_code = kStoppedOnSignal;
        break;
      }
    }
    writer->close();  // shrinks the datasets to the written steps
    update_xdmf(true);
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
        {"steps", figures.step},
        {"steps_planned", steps},
        {"steps_written", writer ? writer->steps_written() : 0},
        {"time", figures.time},
        {"newton_iterations", total_newton},
        {"cg_iterations", total_cg},
        {"accepted_steps", simulation.steps_taken()},
        {"rejected_steps", simulation.controller() ? simulation.controller()->state().rejected : 0},
        {"wall_seconds", wall},
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
    run_figures->steps = simulation.steps_taken();
    run_figures->newton_iterations = total_newton;
    run_figures->cg_iterations = total_cg;
  }
  return exit_code;
}

void register_run(CLI::App& app, Action& action) {
  auto options = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand("run", "Simulate a scene and write its HDF5 trajectory (+ XDMF sidecar)");
  cmd->add_option("scene", options->request.path, "Scene file (YAML)")->required();
  cmd->add_option("-o,--output", options->request.output, "Output file (default: the scene's output.file)");
  add_scene_options(*cmd, options->request);
  add_backend_options(*cmd, options->backend);
  cmd->add_option("--threads", options->threads, "CPU threads (0 = all; default: the scene's solver.threads)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("-q,--quiet", options->quiet, "No progress output");
  cmd->add_flag("--json", options->json, "Print a JSON summary on stdout at the end");
  cmd->add_option("--status-interval", options->status_interval,
                  "Seconds between status lines when stderr is not a terminal")
      ->check(CLI::PositiveNumber);
  cmd->callback([&action, options] { action = [options] { return run_scene(*options); }; });
}

}  // namespace fascia::app
