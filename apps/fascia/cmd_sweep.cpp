// fascia sweep SWEEP.yaml [--list | --task N | --slurm]: a parameter sweep as numbered runs of one
// base scene (sweep_spec.hpp), run one task at a time (a Slurm job array runs them all) and
// gathered by `fascia collect` (docs/hpc.md).
#include "commands.hpp"
#include "run_scene.hpp"
#include "sweep_spec.hpp"

#include "io/checkpoint.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

namespace fascia::app {

namespace {

namespace fs = std::filesystem;

struct SweepOptions {
  std::string file;
  bool list = false;
  bool slurm = false;
  std::optional<int> task;
  RunOptions run;
};

// "finished", "stopped" (a checkpoint to resume from), "pending" (no file yet) or "unreadable".
std::string run_state(const std::string& output) {
  std::error_code ec;
  if (!fs::exists(output, ec)) return "pending";
  try {
    const std::optional<Checkpoint> c = read_checkpoint(output);
    return c && c->finished ? "finished" : "stopped";
  } catch (const std::exception&) {
    return "unreadable";
  }
}

std::string shell_word(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string self_path() {
  std::error_code ec;
  const fs::path p = fs::read_symlink("/proc/self/exe", ec);
  return ec ? "fascia" : p.string();
}

// The sbatch script of the whole sweep as one job array.
std::string slurm_script(const Sweep& sweep) {
  const SlurmSettings& s = sweep.slurm;
  const fs::path folder = fs::absolute(sweep.folder);
  std::ostringstream o;
  o << "#!/bin/bash\n"
    << "# A job array of " << sweep.runs.size() << " runs: fascia sweep " << sweep.file << " --slurm\n"
    << "#SBATCH --job-name=" << sweep.name << "\n"
    << "#SBATCH --array=0-" << sweep.runs.size() - 1 << "\n"
    << "#SBATCH --time=" << s.time << "\n"
    << "#SBATCH --ntasks=1\n"
    << "#SBATCH --cpus-per-task=" << s.cpus_per_task << "\n";
  if (s.gpus_per_task > 0) o << "#SBATCH --gpus-per-task=" << s.gpus_per_task << "\n";
  if (!s.partition.empty()) o << "#SBATCH --partition=" << s.partition << "\n";
  if (!s.account.empty()) o << "#SBATCH --account=" << s.account << "\n";
  o << "#SBATCH --signal=B:USR1@" << static_cast<long>(s.signal_seconds) << "\n"
    << "#SBATCH --requeue\n"
    << "#SBATCH --open-mode=append\n"
    << "#SBATCH --chdir=" << fs::current_path().string() << "\n"
    << "#SBATCH --output=" << (folder / (sweep.name + "-%a.slurm.log")).string() << "\n";
  for (const std::string& line : s.extra) o << "#SBATCH " << line << "\n";
  o << "\n"
    << "# Each task runs (or resumes, or finds finished) its run. The pre-limit signal reaches this\n"
    << "# shell (B:USR1), which passes it on: fascia writes its last step and a checkpoint and exits\n"
    << "# 75, and the task is requeued to resume. fascia runs as a child, not through exec, so that\n"
    << "# this shell is still there to requeue.\n"
    << "export OMP_NUM_THREADS=\"${SLURM_CPUS_PER_TASK:-1}\"\n"
    << "export OMP_WAIT_POLICY=passive\n"
    << shell_word(self_path()) << " sweep " << shell_word(fs::absolute(sweep.file).string())
    << " --task \"$SLURM_ARRAY_TASK_ID\" --threads \"$OMP_NUM_THREADS\" --quiet"
    << (s.gpus_per_task > 0 ? " --backend cuda" : "") << " &\n"
    << "pid=$!\n"
    << "trap 'kill -USR1 \"$pid\" 2>/dev/null' USR1 TERM\n"
    << "while :; do\n"
    << "  wait \"$pid\"; rc=$?\n"
    << "  kill -0 \"$pid\" 2>/dev/null || break  # wait returned for a trapped signal: wait again\n"
    << "done\n"
    << "if [ \"$rc\" -eq 75 ]; then\n"
    << "  echo \"fascia: task $SLURM_ARRAY_TASK_ID stopped with a checkpoint; requeued\"\n"
    << "  scontrol requeue \"${SLURM_ARRAY_JOB_ID}_${SLURM_ARRAY_TASK_ID}\"\n"
    << "fi\n"
    << "exit \"$rc\"\n";
  return o.str();
}

// <folder>/<name>.json, replaced atomically: what the task's last attempt ended with.
void write_task_record(const SweepRun& run, int code, double wall) {
  nlohmann::json j;
  j["task"] = run.task;
  j["name"] = run.name;
  j["output"] = run.output;
  nlohmann::json parameters = nlohmann::json::object();
  for (const auto& [path, value] : run.parameters) parameters[path] = value;
  j["parameters"] = parameters;
  j["exit_code"] = code;
  j["status"] = code == kOk ? "finished" : code == kStoppedOnSignal ? "stopped" : code == kSolverFailed ? "failed" : "refused";
  j["wall_seconds"] = wall;
  const std::time_t now = std::time(nullptr);
  char stamp[64];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  j["ended"] = stamp;
  for (const char* key : {"SLURM_JOB_ID", "SLURM_ARRAY_JOB_ID", "SLURM_ARRAY_TASK_ID", "SLURM_RESTART_COUNT"})
    if (const char* v = std::getenv(key)) j[key] = v;
  const fs::path path = fs::path(run.output).replace_extension(".json");
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp);
    out << j.dump(2) << "\n";
    if (!out) return;
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
}

int sweep(SweepOptions options) {
  Sweep sweep;
  try {
    sweep = read_sweep(options.file);
  } catch (const dsl::SceneError& e) {
    for (const dsl::Diagnostic& d : e.diagnostics().sorted()) std::cerr << d.str() << "\n";
    return static_cast<int>(e.exit_code());
  }
  if (options.slurm) {
    std::error_code ec;
    fs::create_directories(sweep.folder, ec);  // Slurm opens the task logs there before the script starts
    if (ec) {
      std::cerr << "fascia: error: cannot create " << sweep.folder << ": " << ec.message() << "\n";
      return kCantCreate;
    }
    std::cout << slurm_script(sweep);
    return kOk;
  }
  if (!options.task && !options.list) {
    if (const char* id = std::getenv("SLURM_ARRAY_TASK_ID")) {
      char* end = nullptr;
      const long n = std::strtol(id, &end, 10);
      if (*id && !*end) options.task = static_cast<int>(n);
    }
  }
  if (options.task) {
    const int n = *options.task;
    if (n < 0 || n >= static_cast<int>(sweep.runs.size())) {
      std::cerr << "fascia: error: task " << n << " is not in the sweep (0 to " << sweep.runs.size() - 1 << ")\n";
      return kUsage;
    }
    const SweepRun& run = sweep.runs[static_cast<std::size_t>(n)];
    std::error_code ec;
    fs::create_directories(sweep.folder, ec);
    RunOptions r = options.run;
    r.request.path = sweep.scene;
    r.request.output = run.output;
    r.request.overrides = run.overrides;
    r.resume = true;  // a finished task does nothing, a stopped one continues, a new one starts
    const auto t0 = std::chrono::steady_clock::now();
    const int code = run_scene(r);
    write_task_record(run, code, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    return code;
  }
  // --list: the runs and where each stands.
  if (options.run.json) {
    nlohmann::json runs = nlohmann::json::array();
    for (const SweepRun& run : sweep.runs) {
      nlohmann::json parameters = nlohmann::json::object();
      for (const auto& [path, value] : run.parameters) parameters[path] = value;
      runs.push_back({{"task", run.task}, {"name", run.name}, {"output", run.output}, {"state", run_state(run.output)},
                      {"parameters", parameters}, {"set", run.overrides}});
    }
    std::cout << nlohmann::json{{"sweep", sweep.file}, {"scene", sweep.scene}, {"runs", runs}}.dump(2) << "\n";
    return kOk;
  }
  std::cout << sweep.runs.size() << " runs of " << sweep.scene << " into " << sweep.folder << "/\n";
  std::cout << std::left << std::setw(6) << "task" << std::setw(10) << "state";
  for (const std::string& p : sweep.parameter_names) std::cout << "  " << p;
  std::cout << "\n";
  for (const SweepRun& run : sweep.runs) {
    std::cout << std::left << std::setw(6) << run.task << std::setw(10) << run_state(run.output);
    for (const auto& [path, value] : run.parameters) std::cout << "  " << value;
    std::cout << "\n";
  }
  return kOk;
}

}  // namespace

void register_sweep(CLI::App& app, Action& action) {
  auto options = std::make_shared<SweepOptions>();
  CLI::App* cmd = app.add_subcommand("sweep", "Run a parameter sweep: list its runs, run one task, or write a Slurm job array");
  cmd->add_option("sweep", options->file, "Sweep file (YAML: scene, set, cross, zip, slurm)")->required();
  CLI::Option* list = cmd->add_flag("--list", options->list, "List the runs and their state (the default)");
  CLI::Option* slurm =
      cmd->add_flag("--slurm", options->slurm, "Print an sbatch script running the sweep as one job array")->excludes(list);
  cmd->add_option_function<int>(
         "--task", [options](const int& n) { options->task = n; },
         "Run task N (default: $SLURM_ARRAY_TASK_ID): start, resume or find it finished")
      ->excludes(list)
      ->excludes(slurm);
  add_run_options(*cmd, options->run);
  cmd->callback([&action, options] { action = [options] { return sweep(*options); }; });
}

}  // namespace fascia::app
