// Host-side checks of the CUDA backend's adapter (no GPU needed): on a model without samples
// (shells and rigid bodies only) CudaElasticity has no volumetric energy and never touches the
// device, so such scenes run with `--backend cuda` wherever the program starts; the device
// comparisons are in test_cuda_simulation.cpp ([gpu]).
#include "cuda_elasticity.hpp"
#include "support/backend_comparison.hpp"
#include "support/coupling_fixtures.hpp"

#include <catch2/catch.hpp>

#include <random>

using namespace fascia;
using namespace fascia::gpu;
using namespace fascia::test;

TEST_CASE("CudaElasticity on a model without samples is zero and needs no device", "[kernels][backend]") {
  const Model model = shells_and_rigid_model();
  REQUIRE(model.sample_count() == 0);
  const int n = model.frame_count(), dofs = model.dof_count();
  CudaElasticity elasticity(model);  // would throw here without a device if it allocated one
  CHECK(elasticity.device() == nullptr);
  const State state = random_state(model, 5, 0.01, 0.3);

  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> d(dofs), diagonal(10 * n);
  for (double& x : d) x = u(rng);
  for (double& x : diagonal) x = u(rng);
  std::vector<double> g(dofs, 1.0), out(dofs, 1.0), blocks(36 * n, 1.0);
  CHECK(elasticity.energy(state) == 0.0);
  CHECK(elasticity.gradient(state, g.data()) == 0.0);
  CHECK(elasticity.prepare(state) == 0.0);
  CHECK(max_abs(g) == 0.0);
  elasticity.tangent_diagonal_blocks(blocks.data());
  CHECK(max_abs(blocks) == 0.0);
  elasticity.apply_tangent(d.data(), out.data());
  CHECK(max_abs(out) == 0.0);
  // With frame_diagonal: out_i = [t_i dx_i, Q_i dr_i] exactly.
  elasticity.apply_tangent(d.data(), out.data(), diagonal.data());
  for (int i = 0; i < n; ++i) {
    const double* e = &diagonal[10 * i];
    for (int k = 0; k < 3; ++k) CHECK(out[6 * i + k] == e[0] * d[6 * i + k]);
    for (int r = 0; r < 3; ++r)
      CHECK(out[6 * i + 3 + r] ==
            Approx(e[1 + 3 * r] * d[6 * i + 3] + e[2 + 3 * r] * d[6 * i + 4] + e[3 + 3 * r] * d[6 * i + 5])
                .epsilon(1e-15));
  }
  // The assembled tangent's CPU reference: a prepared Elasticity of the same (empty) model.
  CHECK(&elasticity.prepared_reference().model() == &model);
}

TEST_CASE("shells and rigid bodies step alike with the CUDA backend and no samples", "[kernels][backend]") {
  const LinearMethod method = GENERATE(LinearMethod::pcg, LinearMethod::cholmod);
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  SimulationSettings settings;
  settings.integrator = Integrator::backward_euler;
  settings.dt = 0.01;
  settings.rayleigh_mass = 0.5;
  settings.rayleigh_stiffness = 0.002;
  settings.newton.tolerance = 1e-10;
  settings.newton.linear.method = method;
  settings.newton.linear.tolerance = 1e-10;
  const double worst = check_backends_agree(method == LinearMethod::pcg ? "no samples, pcg" : "no samples, cholmod",
                                            shells_and_rigid_model(), loads, settings, cuda_elasticity_factory(), 3);
  CHECK(worst <= 1.0);
}
