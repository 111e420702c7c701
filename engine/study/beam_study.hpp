// The cantilever convergence study of the paper's §4.1 and Figure 3: a 16 x 1 x 1 m beam of
// 5 kg, E = 40 kPa, nu = 0.3, clamped at x = 0, bending under its own weight (g = 9.81 m/s^2
// along -z), solved to static equilibrium. The deflection is large (about half the length), so
// the solve is geometrically nonlinear.
#pragma once

#include "core/small_math.hpp"
#include "integrate/step_backend.hpp"
#include "material/material.hpp"
#include "mechanics/volumetric_elasticity.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace fascia {

struct BeamCase {
  // frame-hex | frame-tet | fem-hex | fem-tet | frame-meshless-mls
  std::string method;
  // Mesh-based: hexahedra per axis (tetrahedra: 6 per hexahedron). Meshless: cells of the grid of
  // spacing about frame_spacing (meshless_beam_resolution), for comparison with the mesh rows.
  int nx = 0, ny = 0, nz = 0;
  double frame_spacing = 0;  // m, meshless methods only (r_f)
};


struct BeamSettings {
  double length = 16, width = 1, height = 1;  // m
  double mass = 5;                            // kg
  double young = 40e3, poisson = 0.3;         // Pa, -
  double gravity = 9.81;                      // m/s^2, along -z
  MaterialLaw law = MaterialLaw::stvk;
  double samples_per_frame = 10;              // meshless: r_s = r_f / cbrt(samples_per_frame)
  std::uint64_t seed = 1;                     // meshless: Poisson-disk seed
  double tolerance = 1e-7;                    // Newton, relative to the weight
  int threads = 0;
  ElasticityFactory elasticity;               // backend of the volumetric elasticity; empty: CPU
  StepBackendFactory step_backend;            // the whole step's backend where it covers the row; empty: CPU
};

struct BeamResult {
  BeamCase beam;
  int frames = 0, samples = 0, dofs = 0;
  Vec3 tip_displacement{0, 0, 0};  // of the free end's centre (16, 0.5, 0.5), m
  int clamped_frames = 0;
  double seconds = 0;
  int newton_iterations = 0;
  double residual = 0;  // relative to the weight, when converged
  bool converged = false;
  std::string message;
};

bool is_meshless_beam_method(const std::string& method);
// A meshless case with its resolution filled in.
BeamCase meshless_beam_case(const std::string& method, double frame_spacing, const BeamSettings& settings = {});

// Mesh-based methods: frame-* use 6-DOF frames at the vertices; fem-* lock the rotations
// (classic total-Lagrangian FEM, DESIGN.md). Hexahedra carry 2x2x2 samples, tetrahedra 4.
// Meshless method (study/meshless_beam.hpp): Poisson-disk frames and samples in the box with MLS
// shape functions and consistent integration, a grid of fixed frames on x = 0, the tip probe
// evaluated with the same shape functions.
BeamResult run_beam_case(const BeamCase& beam, const BeamSettings& settings);

// Resolutions up to 64 x 4 x 4 hexahedra, including the paper's 20 x 9 frames (19 x 2 x 2), and
// meshless frame spacings 1, 0.5, 0.35 and 0.25 m.
std::vector<BeamCase> default_beam_cases();
std::vector<double> default_meshless_frame_spacings();

// Inextensible elastica reference for the same load (Euler-Bernoulli, large rotations, dead
// load): EI theta'' = -q (L - s) cos theta, theta(0) = 0, theta'(L) = 0, solved by shooting on
// theta'(0) with RK4 (4000 steps, bisection to round-off). Returns the tip displacement
// (dx, 0, dz) of the beam axis; the 3D model adds shear and Poisson effects of order (h/L)^2.
Vec3 beam_elastica_deflection(const BeamSettings& settings);

// Euler-Bernoulli small-deflection estimate q L^4 / (8 E I) (m): a sanity scale, not the answer
// for this strongly nonlinear case.
double beam_linear_deflection(const BeamSettings& settings);

}  // namespace fascia
