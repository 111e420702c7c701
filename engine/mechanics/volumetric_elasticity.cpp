#include "mechanics/volumetric_elasticity.hpp"

#include "mechanics/elasticity.hpp"

namespace fascia {

std::unique_ptr<VolumetricElasticity> make_cpu_elasticity(const Model& model, int threads) {
  return std::make_unique<Elasticity>(model, threads);
}

std::unique_ptr<VolumetricElasticity> make_elasticity(const ElasticityFactory& factory, const Model& model,
                                                      int threads, ElasticityUse use) {
  return factory ? factory(model, threads, use) : make_cpu_elasticity(model, threads);
}

}  // namespace fascia
