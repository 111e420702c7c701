#include "cmd_bench_gpu.hpp"

#include "bench/step_bench.hpp"
#include "device_elasticity.hpp"
#include "device_step.hpp"
#include "discretise/mesh_based.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <set>
#include <string>
#include <vector>

namespace fascia::app {
namespace {

// A block of hexahedra with 2x2x2 samples each (8 neighbours), about `target` samples.
Model hex_block(long long target) {
  const long long cells = std::max(1LL, target / 8);
  // nx = 2 ny = 2 nz.
  const int nz = std::max(1, static_cast<int>(std::lround(std::cbrt(cells / 4.0))));
  const int ny = nz, nx = static_cast<int>(std::max(1LL, cells / (static_cast<long long>(ny) * nz)));
  const double h = 0.01;
  const VolumeMesh mesh = box_hex_mesh({0, 0, 0}, {h * nx, h * ny, h * nz}, nx, ny, nz);
  Model model = build_mesh_model(mesh, make_material(MaterialLaw::stvk, 1e5, 0.3, 1000), {});
  fix_frames(model, [](double x, double, double) { return x < 1e-9; });
  return model;
}

struct Row {
  std::string gpu;
  int samples = 0, frames = 0, neighbours = 0;
  std::string precision, design, linear, cg_kernel;
  double ms_per_step = 0, ms_per_cg_iteration = 0, tangent_ms = 0, tangent_gbs = 0, peak_gbs = 0;
  int tangent_registers = 0;            // the launched tangent sample kernel's registers per thread
  long long tangent_local_bytes = 0;    // ... and local memory per thread (spills)
  double paper_ms = NAN, paper_cpu_ms = NAN;
};

struct Case {
  LinearMethod linear;
  bool persistent;
  gpu::DeviceOptions device;
};

// The on/off options of the coalesced pass that the benchmark compares: flag, DeviceOptions
// member, help (BenchGpuOptions::switches, by member name).
struct Switch {
  const char* flag;
  const char* name;
  bool gpu::DeviceOptions::*member;
  const char* help;
};
const Switch kSwitches[] = {
    {"--dense-tangent", "dense_tangent", &gpu::DeviceOptions::dense_tangent,
     "launched tangent product: kernel compiled for the most blocks per multiprocessor without local memory (1, "
     "the default) or for blocks of up to 512 threads (0)"},
    {"--shape-classes", "shape_classes", &gpu::DeviceOptions::shape_classes,
     "launched tangent product: w and g from the samples' shape classes where the model has them (1) or read per "
     "pair (0, the default)"},
    {"--slot-frames", "slot_frames", &gpu::DeviceOptions::slot_frames,
     "launched dense tangent product: each block's frames staged once in shared memory (1) or gathered per pair "
     "(0, the default)"},
    {"--direction-pass", "direction_pass", &gpu::DeviceOptions::direction_pass,
     "launched PCG: the direction p = z + beta p formed in its own pass (1) or by the tangent and frame passes (0, "
     "the default)"},
    {"--hold-pairs", "hold_pairs", &gpu::DeviceOptions::hold_pairs,
     "launched dense tangent product with 2 or 4 held entries: their pairs' levers held in registers for the "
     "output half (1) or gathered again (0, the default)"},
    {"--resident-frames", "resident_frames", &gpu::DeviceOptions::resident_frames,
     "resident PCG in double: the blocks' lever records, directions and materials staged in shared memory (1, the "
     "default) or read each iteration (0)"},
    {"--group-samples", "group_samples", &gpu::DeviceOptions::group_samples,
     "launched tangent product: the grouped pass, eight threads per group of samples with the same frames (1, the "
     "default, where the model has such groups), or the coalesced pass per pair (0)"},
    {"--group-classes", "group_classes", &gpu::DeviceOptions::group_classes,
     "grouped pass: w and g from the groups' classes and maps (1, where the model has them) or read per pair (0, "
     "the default)"},
    {"--frame-threads", "frame_threads", &gpu::DeviceOptions::frame_threads,
     "launched frame pass of the tangent product: one thread per frame (1, the default) or per frame row (0)"},
    {"--prefetch-frames", "prefetch_frames", &gpu::DeviceOptions::prefetch_frames,
     "launched dense tangent product with 2 or 4 held entries: the next pairs' frames read with the held entries "
     "(1) or with their own entries (0, the default)"},
};

// Prints "<what> not used: <why>" to stderr once per run for each distinct reason (every size and
// precision of a sweep would otherwise repeat it); nothing where `why` is empty.
void note_refusal(const char* what, const std::string& why) {
  static std::set<std::string> printed;
  if (why.empty()) return;
  const std::string line = std::string(what) + " not used: " + why;
  if (printed.insert(line).second) std::fprintf(stderr, "%s\n", line.c_str());
}

// The benchmark step of engine/bench/step_bench.hpp (the one `fascia bench cpu` times) on the device.
Row measure(const Model& model, const Case& c, int repeats, const gpu::DeviceInfo& info, bool tangent) {
  const gpu::DeviceOptions& options = c.device;
  gpu::DeviceElasticity dev(model, options);
  note_refusal("shape classes", dev.shape_classes_refusal());
  note_refusal("grouped pass", dev.group_samples_refusal());
  if (dev.group_samples()) note_refusal("group classes", dev.group_classes_refusal());
  const State start = rest_state(model);
  dev.set_state(start);
  gpu::StepOptions so = gpu::make_step_options(model, bench_step_loads(), start, kBenchStepDt, 0, 0,
                                               bench_linear_settings(c.linear, 60));
  so.persistent = c.persistent;
  gpu::DeviceBackwardEuler stepper(dev, so);
  const gpu::StepReport report = stepper.step();
  Row row;
  row.gpu = info.name;
  row.samples = model.sample_count();
  row.frames = model.frame_count();
  row.neighbours = model.max_neighbours();
  row.precision = gpu::to_string(options.precision);
  row.design = gpu::to_string(dev.design());
  if (dev.design() == gpu::Design::fused && dev.sample_pass() == gpu::SamplePass::staged)
    row.design += "/staged";
  else if (dev.design() == gpu::Design::fused)
    row.design += std::string("/") +
                  (dev.sample_pass() == gpu::SamplePass::records     ? "R"
                   : dev.sample_pass() == gpu::SamplePass::coalesced ? "C"
                                                                     : "L") +
                  std::to_string(dev.lanes()) + "x" + std::to_string(options.lane_threads) + "b" +
                  std::to_string(options.block_samples) +
                  (dev.sample_pass() == gpu::SamplePass::records ? "k" + std::to_string(options.record_keep) : "") +
                  (dev.sample_pass() == gpu::SamplePass::coalesced && options.coalesced_keep > 0
                       ? "k" + std::to_string(options.coalesced_keep)
                       : "") +
                  (dev.sample_pass() == gpu::SamplePass::coalesced ? "s" + std::to_string(options.slot_lanes) : "") +
                  (dev.dense_tangent() ? "d" : "") + (dev.shape_classes() ? "m" : "") + (dev.slot_frames() ? "f" : "") +
                  (dev.direction_pass() ? "p" : "") + (dev.hold_pairs() ? "h" : "") +
                  (dev.resident_frames() ? "l" : "") + (dev.prefetch_frames() ? "x" : "") + (dev.group_samples() ? (dev.group_classes() ? "gc" : "g") : "") +
                  (options.row_frames != gpu::DeviceOptions{}.row_frames ? "r" + std::to_string(options.row_frames) : "") +
                  (options.frame_threads ? "" : "R");
  row.linear = to_string(c.linear);
  row.cg_kernel = report.resident ? "resident" : report.persistent ? "persistent" : "launches";
  row.ms_per_step = stepper.time_step_ms(repeats);
  row.ms_per_cg_iteration = stepper.time_cg_iteration_ms(std::max(1, repeats / 2));
  if (tangent) {
    dev.prepare();
    row.tangent_ms = dev.time_tangent_ms(std::max(10, 5 * repeats));
    row.tangent_gbs = dev.tangent_bytes() / (row.tangent_ms * 1e-3) / 1e9;
    const gpu::KernelResources k = dev.tangent_kernel_resources();
    row.tangent_registers = k.registers;
    row.tangent_local_bytes = k.local_bytes;
  }
  row.peak_gbs = info.peak_bandwidth_gbs;
  return row;
}

void print(const Row& r, bool json) {
  if (json) {
    nlohmann::json j = {{"gpu", r.gpu},
                        {"samples", r.samples},
                        {"frames", r.frames},
                        {"neighbours", r.neighbours},
                        {"precision", r.precision},
                        {"design", r.design},
                        {"linear", r.linear},
                        {"cg_kernel", r.cg_kernel},
                        {"ms_per_step", r.ms_per_step},
                        {"ms_per_cg_iteration", r.ms_per_cg_iteration},
                        {"tangent_ms", r.tangent_ms},
                        {"tangent_gbs", r.tangent_gbs},
                        {"tangent_registers", r.tangent_registers},
                        {"tangent_local_bytes", r.tangent_local_bytes},
                        {"peak_gbs", r.peak_gbs}};
    j["paper_ms"] = std::isnan(r.paper_ms) ? nlohmann::json(nullptr) : nlohmann::json(r.paper_ms);
    j["paper_cpu_ms"] = std::isnan(r.paper_cpu_ms) ? nlohmann::json(nullptr) : nlohmann::json(r.paper_cpu_ms);
    std::cout << j.dump() << std::endl;
    return;
  }
  char paper[64] = "      -        -";
  if (!std::isnan(r.paper_ms)) std::snprintf(paper, sizeof paper, "%8.2f %8.2f", r.paper_cpu_ms, r.paper_ms);
  std::printf("%9d %8d %3d %-6s %-5s %-3s %-10s %10.3f %10.4f %17s %9.4f %7.0f (%3.0f%%)\n", r.samples, r.frames,
              r.neighbours, r.precision.c_str(), r.design.c_str(), r.linear.c_str(), r.cg_kernel.c_str(),
              r.ms_per_step, r.ms_per_cg_iteration, paper, r.tangent_ms, r.tangent_gbs,
              r.peak_gbs > 0 ? 100 * r.tangent_gbs / r.peak_gbs : 0.0);
  std::fflush(stdout);
}

// Every element of `in` with each of `values` set by `set(options, value)`, the new values varying
// fastest.
template <class Set>
std::vector<gpu::DeviceOptions> expand(const std::vector<gpu::DeviceOptions>& in, const std::vector<int>& values,
                                       Set set) {
  std::vector<gpu::DeviceOptions> out;
  for (const gpu::DeviceOptions& d : in)
    for (int v : values) {
      gpu::DeviceOptions e = d;
      set(e, v);
      out.push_back(e);
    }
  return out;
}

// The device options of one sample pass: the base options with every compared value of the
// options that apply to it (the others keep their first value, or their default).
std::vector<gpu::DeviceOptions> pass_options(const BenchGpuOptions& o, gpu::DeviceOptions base, gpu::SamplePass pass) {
  base.sample_pass = pass;
  base.lane_threads = o.lane_threads;
  base.block_samples = o.block_samples;
  base.persistent_blocks_per_sm = o.persistent_blocks_per_sm;
  if (pass == gpu::SamplePass::staged) {
    base.lanes = 1;
    return {base};
  }
  const bool records = pass == gpu::SamplePass::records, coalesced = pass == gpu::SamplePass::coalesced;
  // The values given, or the DeviceOptions default where none were.
  const auto given_or = [](const std::vector<int>& values, int fallback) {
    return values.empty() ? std::vector<int>{fallback} : values;
  };
  const auto applying = [](bool applies, const std::vector<int>& values) {
    return applies ? values : std::vector<int>{values.front()};
  };
  std::vector<gpu::DeviceOptions> out = {base};
  out = expand(out, given_or(o.lanes, base.lanes), [](gpu::DeviceOptions& d, int v) { d.lanes = v; });
  out = expand(out, applying(records, given_or(o.record_keep, base.record_keep)),
               [](gpu::DeviceOptions& d, int v) { d.record_keep = v; });
  out = expand(out, given_or(o.row_frames, base.row_frames), [](gpu::DeviceOptions& d, int v) { d.row_frames = v; });
  out = expand(out, applying(coalesced, given_or(o.keep, base.coalesced_keep)),
               [](gpu::DeviceOptions& d, int v) { d.coalesced_keep = v; });
  out = expand(out, applying(coalesced, given_or(o.slot_lanes, base.slot_lanes)),
               [](gpu::DeviceOptions& d, int v) { d.slot_lanes = v; });
  out = expand(out, applying(coalesced, o.resident), [](gpu::DeviceOptions& d, int v) {
    d.resident = v != 0;
    d.resident_double = v == 2;
  });
  for (const Switch& sw : kSwitches) {
    const auto given = o.switches.find(sw.name);
    if (given == o.switches.end() || given->second.empty()) continue;
    out = expand(out, applying(coalesced, given->second),
                 [&sw](gpu::DeviceOptions& d, int v) { d.*sw.member = v != 0; });
  }
  return out;
}

std::vector<Case> cases(const BenchGpuOptions& o) {
  std::vector<Case> out;
  for (gpu::Precision pr : {gpu::Precision::double_precision, gpu::Precision::single_precision}) {
    if (o.precision != "both" && o.precision != gpu::to_string(pr)) continue;
    for (gpu::Design de : {gpu::Design::fused, gpu::Design::paper}) {
      if (o.design != "both" && o.design != gpu::to_string(de)) continue;
      for (LinearMethod lm : {LinearMethod::cg, LinearMethod::pcg}) {
        if (o.linear != "both" && o.linear != to_string(lm)) continue;
        for (bool persistent : {true, false}) {
          if (de == gpu::Design::paper && persistent) continue;  // launches per phase only
          if (o.cg_kernel != "both" && (o.cg_kernel == "persistent") != persistent) continue;
          gpu::DeviceOptions base;
          base.precision = pr;
          base.design = de;
          if (de == gpu::Design::paper) {
            out.push_back(Case{lm, persistent, base});
            continue;
          }
          for (const std::string& name : o.sample_pass) {
            const gpu::SamplePass pass = name == "staged"      ? gpu::SamplePass::staged
                                         : name == "lanes"     ? gpu::SamplePass::lanes
                                         : name == "coalesced" ? gpu::SamplePass::coalesced
                                                               : gpu::SamplePass::records;
            for (const gpu::DeviceOptions& d : pass_options(o, base, pass)) out.push_back(Case{lm, persistent, d});
          }
        }
      }
    }
  }
  return out;
}

}  // namespace

double time_cuda_step(const Model& model, LinearMethod linear, int cg_iterations, const std::string& precision,
                      const std::string& design, int repeats) {
  gpu::DeviceOptions options;
  options.precision = precision == "single" ? gpu::Precision::single_precision : gpu::Precision::double_precision;
  options.design = design == "paper" ? gpu::Design::paper : gpu::Design::fused;
  gpu::DeviceElasticity dev(model, options);
  const State start = rest_state(model);
  dev.set_state(start);
  gpu::DeviceBackwardEuler stepper(dev, gpu::make_step_options(model, bench_step_loads(), start, kBenchStepDt, 0, 0,
                                                               bench_linear_settings(linear, cg_iterations)));
  return stepper.time_step_ms(repeats);
}

bool cuda_device_available(std::string* name) {
  const gpu::DeviceInfo info = gpu::device_info();
  if (name) *name = info.name;
  return info.device_count > 0;
}

int run_bench_gpu(const BenchGpuOptions& o) {
  const gpu::DeviceInfo info = gpu::device_info();
  if (info.device_count == 0) {
    std::cerr << "fascia bench gpu: no CUDA device\n";
    return kUnavailable;
  }
  const std::vector<Case> all = cases(o);
  const int repeats = o.quick ? 3 : o.repeats;
  if (!o.json) {
    std::printf("fascia bench gpu on %s (%d SMs, %.0f GiB, peak DRAM %.0f GB/s from clock x bus width)\n",
                info.name.c_str(), info.multiprocessors, info.memory_gib, info.peak_bandwidth_gbs);
    std::printf("ms per full implicit step (the step of `fascia bench cpu`): forces + preparation + 60 CG\n"
                "iterations + update, CUDA events\n");
    std::printf("%9s %8s %3s %-6s %-5s %-3s %-10s %10s %10s %8s %8s %9s %15s\n", "samples", "frames", "nb", "prec",
                "design", "lin", "cg kernel", "ms/step", "ms/CG it", "CPU'13", "GTX570", "Kd ms", "Kd GB/s (peak)");
  }
  for (const PaperTiming& p : paper_table3()) {
    if (!o.sizes.empty() && std::find(o.sizes.begin(), o.sizes.end(), p.samples) == o.sizes.end()) continue;
    const Model model = bench_beam_model(p.samples, 4);
    for (const Case& c : all) {
      Row r = measure(model, c, repeats, info, o.tangent);
      r.paper_ms = p.gpu_ms;
      r.paper_cpu_ms = p.cpu_ms;
      print(r, o.json);
    }
  }
  std::vector<long long> scaling = {131072, 524288, 1048576, 2097152, o.max_samples};
  if (o.quick) scaling = {o.max_samples};
  if (o.max_samples <= 0) scaling.clear();
  for (long long target : scaling) {
    if (target > o.max_samples) continue;
    const auto t0 = std::chrono::steady_clock::now();
    const Model model = hex_block(target);
    const double build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::fprintf(stderr, "built %d samples in %.1f s\n", model.sample_count(), build_s);
    for (const Case& c : all) print(measure(model, c, repeats, info, true), o.json);
  }
  return 0;
}

void add_bench_gpu_command(CLI::App& bench, Action& action) {
  auto options = std::make_shared<BenchGpuOptions>();
  CLI::App* cmd = bench.add_subcommand("gpu", "ms per implicit step on the CUDA backend (paper Table 3 sizes, scaling)");
  cmd->add_flag("--json", options->json, "one JSON object per line");
  cmd->add_flag("--quick", options->quick, "Table 3 sizes and the largest case only, fewer repeats");
  cmd->add_option("--precision", options->precision, "double | single | both")
      ->check(CLI::IsMember({"double", "single", "both"}));
  cmd->add_option("--design", options->design, "fused | paper | both")->check(CLI::IsMember({"fused", "paper", "both"}));
  cmd->add_option("--linear", options->linear, "cg | pcg | both (the linear solve of the step)")
      ->check(CLI::IsMember({"cg", "pcg", "both"}));
  cmd->add_option("--cg-kernel", options->cg_kernel,
                  "persistent (one cooperative kernel per PCG) | launches (kernels per phase) | both")
      ->check(CLI::IsMember({"persistent", "launches", "both"}));
  cmd->add_option("--samples", options->sizes, "only these Table 3 sizes");
  cmd->add_flag("--tangent", options->tangent, "also time the tangent product alone at Table 3 sizes");
  cmd->add_option("--max-samples", options->max_samples, "largest scaling case (8 neighbours), 0: none");
  cmd->add_option("--repeats", options->repeats, "timed repeats per case");
  cmd->add_option("--sample-pass", options->sample_pass,
                  "fused design's tangent sample passes: coalesced (ELL pairs, component-major samples, arithmetic "
                  "in the storage precision) | lanes (F and material cache per sample) | records (packed records, F "
                  "rebuilt) | staged (shared-memory staging)")
      ->check(CLI::IsMember({"coalesced", "records", "lanes", "staged"}));
  cmd->add_option("--lanes", options->lanes, "fused design, records and lanes passes: threads per sample, 0: auto");
  cmd->add_option("--lane-threads", options->lane_threads, "fused design: most threads per tangent block (32..512)");
  cmd->add_option("--record-keep", options->record_keep,
                  "records pass: pairs per lane kept in registers (1 | 2), several to compare")
      ->check(CLI::Range(1, 2));
  cmd->add_option("--keep", options->keep,
                  "coalesced pass: ELL entries per lane held in registers (0: auto | 2 | 4 | 8), several to compare")
      ->check(CLI::IsMember({0, 2, 4, 8}));
  cmd->add_option("--slot-lanes", options->slot_lanes,
                  "coalesced pass: lanes per slot sum (1 | 2 | 4 | 8 | 16 | 32), several to compare")
      ->check(CLI::IsMember({1, 2, 4, 8, 16, 32}));
  cmd->add_option("--resident", options->resident,
                  "coalesced pass, persistent PCG: loop invariants held in the kernel in single precision (1), in "
                  "both precisions (2, the default) or not (0), several to compare")
      ->check(CLI::IsMember({0, 1, 2}));
  for (const Switch& sw : kSwitches)
    cmd->add_option(sw.flag, options->switches[sw.name],
                    std::string("coalesced pass, ") + sw.help + ", several to compare")
        ->check(CLI::IsMember({0, 1}));
  cmd->add_option("--row-frames", options->row_frames,
                  "frames per block of the launched frame-row passes (1..85), several to compare")
      ->check(CLI::Range(1, 85));
  cmd->add_option("--block-samples", options->block_samples, "fused design: samples per block (multiple of 32)");
  cmd->add_option("--persistent-blocks-per-sm", options->persistent_blocks_per_sm,
                  "persistent PCG while the model needs at most this many blocks per multiprocessor");
  cmd->callback([options, &action] { action = [options] { return run_bench_gpu(*options); }; });
}

}  // namespace fascia::app
