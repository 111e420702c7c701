// `fascia study beam`: the paper's cantilever convergence study (§4.1, Figure 3), on the CPU or
// on the CUDA backend (--backend cuda; backend.hpp): each row's static solve on the device where
// the device step covers it, else with the volumetric elasticity on the device.
#include "backend.hpp"
#include "commands.hpp"
#include "number_checks.hpp"
#include "process_threads.hpp"

#include "study/beam_study.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <sstream>

namespace fascia::app {
namespace {

struct StudyOptions {
  bool json = false;
  std::vector<std::string> methods;
  std::vector<std::string> resolutions;  // "NXxNYxNZ", mesh-based methods
  std::vector<double> frame_spacings;    // m, meshless methods
  int threads = 0;
  BackendOptions backend;
  double samples_per_frame = BeamSettings{}.samples_per_frame;
  std::vector<std::uint64_t> seeds{BeamSettings{}.seed};
};

// |tip| over the seeds of one meshless row (m), and max |dy| / |tip|.
struct SeedSummary {
  int count = 0;
  double sum = 0, min = 1e300, max = 0, lateral = 0;
  void add(const Vec3& u) {
    const double n = norm(u);
    ++count, sum += n, min = std::min(min, n), max = std::max(max, n);
    if (n > 0) lateral = std::max(lateral, std::abs(u.y) / n);
  }
};

const char* const kMeshMethods[] = {"frame-hex", "frame-tet", "fem-hex", "fem-tet"};
const char* const kMeshlessMethods[] = {"frame-meshless-mls"};

// --resolution selects mesh-based cases and --frame-spacing meshless ones; with neither, the
// default cases of both.
std::vector<BeamCase> select_cases(const StudyOptions& o, const BeamSettings& settings) {
  std::vector<BeamCase> cases;
  if (o.resolutions.empty() && o.frame_spacings.empty()) {
    cases = default_beam_cases();
  } else {
    for (const char* m : kMeshlessMethods)
      for (double rf : o.frame_spacings) cases.push_back(meshless_beam_case(m, rf, settings));
    for (const char* m : kMeshMethods)
      for (const std::string& r : o.resolutions) {
        BeamCase c{m, 0, 0, 0};
        char x1 = 0, x2 = 0;
        std::istringstream in(r);
        if (!(in >> c.nx >> x1 >> c.ny >> x2 >> c.nz) || x1 != 'x' || x2 != 'x' || c.nx < 1 || c.ny < 1 || c.nz < 1)
          throw CLI::ValidationError("--resolution", "expected NXxNYxNZ with positive integers, got '" + r + "'");
        cases.push_back(c);
      }
  }
  if (!o.methods.empty()) {
    std::vector<BeamCase> kept;
    for (const BeamCase& c : cases)
      for (const std::string& m : o.methods)
        if (c.method == m) kept.push_back(c);
    cases = kept;
  }
  return cases;
}

int run_beam(const StudyOptions& o) {
  bound_process_threads(o.threads);
  Backend backend;
  if (const int code = resolve_backend("study", o.backend, backend); code != kOk) return code;
  BeamSettings settings;
  settings.threads = o.threads;
  settings.elasticity = backend.elasticity;
  settings.step_backend = backend.step;
  settings.samples_per_frame = o.samples_per_frame;
  const std::vector<BeamCase> cases = select_cases(o, settings);
  const Vec3 elastica = beam_elastica_deflection(settings);
  if (!o.json) {
    std::printf("Cantilever 16 x 1 x 1 m, 5 kg, E = 40 kPa, nu = 0.3, own weight (paper §4.1)\n");
    std::printf("small-deflection estimate qL^4/(8EI) = %.3f m; inextensible elastica: tip dx = %.4f m, dz = %.4f m\n",
                beam_linear_deflection(settings), elastica.x, elastica.z);
    std::printf("backend: %s\n\n", backend.description.c_str());
    std::printf("%-18s %-10s %6s %4s %7s %8s %7s %10s %10s %10s %10s %8s\n", "method", "resolution", "r_f", "seed",
                "frames", "samples", "dofs", "tip dx", "tip dy", "tip dz", "|tip|", "seconds");
  }
  bool all_converged = true;
  for (const BeamCase& c : cases) {
    const bool meshless = is_meshless_beam_method(c.method);
    // Meshless rows over every seed, then their mean, spread and largest lateral component.
    SeedSummary summary;
    for (size_t k = 0; k < (meshless ? o.seeds.size() : 1); ++k) {
      if (meshless) settings.seed = o.seeds[k];
      const BeamResult r = run_beam_case(c, settings);
      all_converged = all_converged && r.converged;
      const Vec3 u = r.tip_displacement;
      if (meshless && r.converged) summary.add(u);
      if (o.json) {
        nlohmann::json j = {{"method", c.method},
                            {"resolution", {c.nx, c.ny, c.nz}},
                            {"frames", r.frames},
                            {"samples", r.samples},
                            {"dofs", r.dofs},
                            {"tip_displacement", {u.x, u.y, u.z}},
                            {"seconds", r.seconds},
                            {"converged", r.converged},
                            {"newton_iterations", r.newton_iterations},
                            {"elastica_tip", {elastica.x, elastica.y, elastica.z}}};
        for (const auto& [key, value] : backend.provenance.items()) j[key] = value;  // backend, gpu, precision
        if (meshless) j["frame_spacing"] = c.frame_spacing, j["seed"] = settings.seed;
        std::cout << j.dump() << std::endl;
      } else {
        char rf[16] = "-", seed[24] = "-";
        if (meshless) {
          std::snprintf(rf, sizeof rf, "%.3g", c.frame_spacing);
          std::snprintf(seed, sizeof seed, "%llu", static_cast<unsigned long long>(settings.seed));
        }
        std::printf("%-18s %3dx%dx%-4d %6s %4s %7d %8d %7d %10.5f %10.5f %10.5f %10.5f %8.2f%s\n", c.method.c_str(),
                    c.nx, c.ny, c.nz, rf, seed, r.frames, r.samples, r.dofs, u.x, u.y, u.z, norm(u), r.seconds,
                    r.converged ? "" : "  (not converged)");
        std::fflush(stdout);
      }
      if (!r.converged) std::cerr << "fascia: " << c.method << " " << c.nx << "x" << c.ny << "x" << c.nz << ": " << r.message << "\n";
    }
    if (summary.count < 2) continue;
    const double reference = norm(elastica);
    const double mean = summary.sum / summary.count;
    if (o.json) {
      std::cout << nlohmann::json{{"method", c.method},
                                  {"frame_spacing", c.frame_spacing},
                                  {"seeds", summary.count},
                                  {"tip_norm_mean", mean},
                                  {"tip_norm_min", summary.min},
                                  {"tip_norm_max", summary.max},
                                  {"lateral_max", summary.lateral},
                                  {"elastica_norm", reference}}
                       .dump()
                << std::endl;
    } else {
      std::printf("%-18s %-10s %6.3g over %zu seeds: |tip| mean %.5f m (%+.2f %% vs the elastica), spread %.2f %% "
                  "(max - min), largest |dy| %.3f %% of |tip|\n",
                  c.method.c_str(), "", c.frame_spacing, static_cast<size_t>(summary.count), mean,
                  100 * (mean / reference - 1), 100 * (summary.max - summary.min) / reference,
                  100 * summary.lateral);
      std::fflush(stdout);
    }
  }
  return all_converged ? kOk : kSolverFailed;
}

}  // namespace

void register_study(CLI::App& app, Action& action) {
  CLI::App* study = app.add_subcommand("study", "Reproduce the paper's studies");
  study->require_subcommand(1);
  auto options = std::make_shared<StudyOptions>();
  CLI::App* beam = study->add_subcommand("beam", "Cantilever convergence study (paper §4.1, Figure 3)");
  beam->add_flag("--json", options->json, "One JSON object per line on stdout");
  beam->add_option("--method", options->methods,
                   "Only these methods (frame-hex, frame-tet, fem-hex, fem-tet, frame-meshless-mls)")
      ->check(CLI::IsMember({"frame-hex", "frame-tet", "fem-hex", "fem-tet", "frame-meshless-mls"}));
  beam->add_option("--resolution", options->resolutions, "Mesh-based cases: resolutions NXxNYxNZ (hexahedra per axis)");
  beam->add_option("--frame-spacing", options->frame_spacings, "Meshless cases: frame spacings r_f (m)")
      ->check(kPositiveNumber);
  beam->add_option("--samples-per-frame", options->samples_per_frame,
                   "Meshless cases: r_s = r_f / cbrt(this) (default 10)")
      ->check(CLI::Range(1.01, 1e6));
  beam->add_option("--seed", options->seeds,
                   "Meshless cases: Poisson-disk seeds (default 1); with several, each row is run for every seed "
                   "and followed by the mean, spread and largest lateral component of the tip")
      ->expected(1, -1);
  beam->add_option("--threads", options->threads,
                   "CPU threads of the whole study, the sparse factorisation's BLAS included (0 = all)")->check(kNonNegativeNumber);
  add_backend_options(*beam, options->backend);
  beam->callback([options, &action] { action = [options] { return run_beam(*options); }; });
}

}  // namespace fascia::app
