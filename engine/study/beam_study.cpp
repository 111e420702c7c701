#include "study/beam_study.hpp"

#include "discretise/mesh_based.hpp"
#include "discretise/probe.hpp"
#include "integrate/simulation.hpp"
#include "study/meshless_beam.hpp"

#include <chrono>
#include <stdexcept>

namespace fascia {

namespace {

struct DiscreteBeam {
  Model model;
  Probe tip;
  int clamped_frames = 0;
};

DiscreteBeam discretise_beam(const BeamCase& beam, const BeamSettings& s) {
  if (beam.method == "frame-meshless-mls" || beam.method == "frame-meshless-rbf") {
    const MeshlessShapeKind kind = beam.method == "frame-meshless-mls" ? MeshlessShapeKind::mls : MeshlessShapeKind::rbf;
    MeshlessBeam m = build_meshless_beam(s, kind, beam.frame_spacing);
    return {std::move(m.model), std::move(m.tip), m.clamped_frames};
  }
  const bool tet = beam.method == "frame-tet" || beam.method == "fem-tet";
  const bool fem = beam.method == "fem-hex" || beam.method == "fem-tet";
  if (!tet && beam.method != "frame-hex" && beam.method != "fem-hex")
    throw std::invalid_argument("unknown beam method '" + beam.method + "'");
  const Vec3 lo{0, 0, 0}, hi{s.length, s.width, s.height};
  const VolumeMesh mesh = tet ? box_tet_mesh(lo, hi, beam.nx, beam.ny, beam.nz)
                              : box_hex_mesh(lo, hi, beam.nx, beam.ny, beam.nz);
  const double density = s.mass / (s.length * s.width * s.height);
  DiscreteBeam d{build_mesh_model(mesh, make_material(s.law, s.young, s.poisson, density)), Probe{}, 0};
  if (fem) lock_rotations(d.model);
  const double clamp = 1e-9 * s.length;
  d.clamped_frames = fix_frames(d.model, [clamp](double x, double, double) { return x <= clamp; });
  d.tip = make_probe(mesh, Vec3{s.length, 0.5 * s.width, 0.5 * s.height});
  return d;
}

}  // namespace

bool is_meshless_beam_method(const std::string& method) {
  return method == "frame-meshless-mls" || method == "frame-meshless-rbf";
}

BeamCase meshless_beam_case(const std::string& method, double frame_spacing, const BeamSettings& settings) {
  BeamCase c{method, 0, 0, 0, frame_spacing};
  meshless_beam_resolution(settings, frame_spacing, c.nx, c.ny, c.nz);
  return c;
}

BeamResult run_beam_case(const BeamCase& beam, const BeamSettings& s) {
  const auto t0 = std::chrono::steady_clock::now();
  DiscreteBeam d = discretise_beam(beam, s);
  Model& model = d.model;
  const Probe& tip = d.tip;

  BeamResult result;
  result.beam = beam;
  result.clamped_frames = d.clamped_frames;
  result.frames = model.frame_count();
  result.samples = model.sample_count();
  result.dofs = model.nominal_dof_count();

  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -s.gravity};
  SimulationSettings settings;
  settings.integrator = Integrator::static_equilibrium;
  settings.threads = s.threads;
  settings.newton.tolerance = s.tolerance;
  settings.newton.max_iterations = 400;
  settings.newton.linear.method = LinearMethod::cholmod;
  Simulation sim(std::move(model), loads, settings);
  const Vec3 rest = probe_position(tip, sim.state());
  try {
    const StepReport r = sim.step();
    result.converged = r.converged;
    result.newton_iterations = r.newton_iterations;
  } catch (const SolverError& e) {
    result.message = e.what();
  }
  result.tip_displacement = probe_position(tip, sim.state()) - rest;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

std::vector<BeamCase> default_beam_cases() {
  const int res[][3] = {{4, 1, 1}, {8, 1, 1}, {16, 1, 1}, {8, 2, 2}, {16, 2, 2},
                        {19, 2, 2}, {32, 2, 2}, {32, 4, 4}, {64, 4, 4}};
  std::vector<BeamCase> cases;
  for (const char* method : {"frame-hex", "frame-tet", "fem-hex", "fem-tet"})
    for (const auto& r : res) cases.push_back({method, r[0], r[1], r[2]});
  for (const char* method : {"frame-meshless-mls", "frame-meshless-rbf"})
    for (double rf : default_meshless_frame_spacings()) cases.push_back(meshless_beam_case(method, rf));
  return cases;
}

std::vector<double> default_meshless_frame_spacings() { return {1.0, 0.5, 0.35, 0.25}; }

double beam_linear_deflection(const BeamSettings& s) {
  const double q = s.mass * s.gravity / s.length;               // N/m
  const double I = s.width * s.height * s.height * s.height / 12;  // m^4
  return q * s.length * s.length * s.length * s.length / (8 * s.young * I);
}

}  // namespace fascia
