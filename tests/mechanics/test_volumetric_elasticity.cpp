// The backend interface of the volumetric elasticity: the CPU factory makes fascia::Elasticity,
// and calls through VolumetricElasticity give the bits of direct calls.
#include "mechanics/elasticity.hpp"
#include "mechanics/volumetric_elasticity.hpp"
#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

#include <cstring>
#include <vector>

using namespace fascia;
using namespace fascia::test;

namespace {

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

}  // namespace

TEST_CASE("the default elasticity factory is the CPU reference, bit for bit", "[mechanics][backend]") {
  const CellType type = GENERATE(CellType::hexahedron, CellType::tetrahedron);
  const Model model = small_box_model(type, MaterialLaw::neo_hookean, 3, 2, 2);
  const State state = random_state(model, 11, 0.005, 0.3, 1.0);
  const int n = model.frame_count(), dofs = model.dof_count();

  const std::unique_ptr<VolumetricElasticity> made = make_elasticity({}, model, 2);
  REQUIRE(dynamic_cast<Elasticity*>(made.get()) != nullptr);
  REQUIRE(&made->model() == &model);
  Elasticity direct(model, 2);

  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> d(dofs), diagonal(10 * n);
  for (double& x : d) x = u(rng);
  for (double& x : diagonal) x = u(rng);

  std::vector<double> g1(dofs), g2(dofs), k1(dofs), k2(dofs), kd1(dofs), kd2(dofs), b1(36 * n), b2(36 * n);
  CHECK(made->energy(state) == direct.energy(state));
  CHECK(made->gradient(state, g1.data()) == direct.gradient(state, g2.data()));
  CHECK(made->prepare(state) == direct.prepare(state));
  made->apply_tangent(d.data(), k1.data());
  direct.apply_tangent(d.data(), k2.data());
  made->apply_tangent(d.data(), kd1.data(), diagonal.data());
  direct.apply_tangent(d.data(), kd2.data(), diagonal.data());
  made->tangent_diagonal_blocks(b1.data());
  direct.tangent_diagonal_blocks(b2.data());
  CHECK(same_bits(g1, g2));
  CHECK(same_bits(k1, k2));
  CHECK(same_bits(kd1, kd2));
  CHECK(same_bits(b1, b2));
  CHECK(!same_bits(k1, kd1));  // the frame_diagonal term is applied
  // The CPU reference is its own prepared reference (the assembled tangent reads it directly).
  CHECK(&made->prepared_reference() == made.get());
}

TEST_CASE("an explicit elasticity factory is what make_elasticity calls", "[mechanics][backend]") {
  const Model model = small_box_model(CellType::hexahedron);
  std::vector<ElasticityUse> made;
  const ElasticityFactory counting = [&made](const Model& m, int threads, ElasticityUse use) {
    made.push_back(use);
    return make_cpu_elasticity(m, threads);
  };
  const std::unique_ptr<VolumetricElasticity> e = make_elasticity(counting, model, 1);
  const std::unique_ptr<VolumetricElasticity> d = make_elasticity(counting, model, 1, ElasticityUse::damping);
  CHECK(made == std::vector<ElasticityUse>{ElasticityUse::step, ElasticityUse::damping});
  CHECK(dynamic_cast<Elasticity*>(e.get()) != nullptr);
}
