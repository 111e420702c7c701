#include "study/beam_study.hpp"

#include "discretise/mesh_based.hpp"
#include "discretise/probe.hpp"
#include "integrate/simulation.hpp"
#include "study/meshless_beam.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>

namespace fascia {

namespace {

struct DiscreteBeam {
  Model model;
  Probe tip;
  int clamped_frames = 0;
};

DiscreteBeam discretise_beam(const BeamCase& beam, const BeamSettings& s) {
  if (is_meshless_beam_method(beam.method)) {
    MeshlessBeam m = build_meshless_beam(s, beam.frame_spacing);
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
  return method == "frame-meshless-mls";
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
  settings.elasticity = s.elasticity;
  settings.step_backend = s.step_backend;
  settings.newton.tolerance = s.tolerance;
  // Every row converges in 15-40 iterations (frame hexahedra with their rotation stabilisation,
  // docs/solvers.md); the budget keeps a non-converging row to minutes and the row reports its
  // residual.
  settings.newton.max_iterations = 300;
  settings.max_load_halvings = 1;
  settings.newton.linear.method = LinearMethod::cholmod;
  Simulation sim(std::move(model), loads, settings);
  const Vec3 rest = probe_position(tip, sim.state());
  try {
    const StepReport r = sim.step();
    result.converged = r.converged;
    result.newton_iterations = r.newton_iterations;
    result.residual = r.residual;
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
  for (double rf : default_meshless_frame_spacings()) cases.push_back(meshless_beam_case("frame-meshless-mls", rf));
  return cases;
}

std::vector<double> default_meshless_frame_spacings() { return {1.0, 0.5, 0.35, 0.25}; }

double beam_linear_deflection(const BeamSettings& s) {
  const double q = s.mass * s.gravity / s.length;               // N/m
  const double I = s.width * s.height * s.height * s.height / 12;  // m^4
  return q * s.length * s.length * s.length * s.length / (8 * s.young * I);
}

}  // namespace fascia

namespace fascia {
namespace {

// Integrates theta'' = -c (L - s) cos theta from s = 0 with theta = 0, theta' = k0; returns
// theta'(L) and the tip position (x, z) of the axis.
struct Shot {
  double end_curvature, x, z;
};

Shot shoot(double k0, double c, double L, int steps) {
  const double h = L / steps;
  double theta = 0, k = k0, s = 0, x = 0, z = 0;
  auto rhs = [c, L](double at, double th) { return -c * (L - at) * std::cos(th); };
  for (int n = 0; n < steps; ++n) {
    const double t1 = k, k1 = rhs(s, theta);
    const double t2 = k + 0.5 * h * k1, k2 = rhs(s + 0.5 * h, theta + 0.5 * h * t1);
    const double t3 = k + 0.5 * h * k2, k3 = rhs(s + 0.5 * h, theta + 0.5 * h * t2);
    const double t4 = k + h * k3, k4 = rhs(s + h, theta + h * t3);
    // Position by Simpson's rule over the step with the RK stage angles.
    const double mid = theta + 0.25 * h * (t1 + t2), end = theta + h / 6 * (t1 + 2 * t2 + 2 * t3 + t4);
    x += h / 6 * (std::cos(theta) + 4 * std::cos(mid) + std::cos(end));
    z += h / 6 * (std::sin(theta) + 4 * std::sin(mid) + std::sin(end));
    theta = end;
    k += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
    s += h;
  }
  return {k, x, z};
}

}  // namespace

Vec3 beam_elastica_deflection(const BeamSettings& s) {
  const double I = s.width * s.height * s.height * s.height / 12;
  const double c = s.mass * s.gravity / s.length / (s.young * I);  // q / (E I), 1/m^3
  // theta'(L) increases with theta'(0): bisection between 0 and the linear root curvature x 2.
  double lo = 0, hi = 2 * c * s.length * s.length / 2;
  for (int it = 0; it < 200 && hi - lo > 1e-15 * hi; ++it) {
    const double mid = 0.5 * (lo + hi);
    (shoot(mid, c, s.length, 4000).end_curvature > 0 ? hi : lo) = mid;
  }
  const Shot tip = shoot(lo, c, s.length, 4000);
  return Vec3{tip.x - s.length, 0, -tip.z};
}

}  // namespace fascia
