#include "material/material.hpp"

#include <stdexcept>

namespace fascia {

Material make_material(MaterialLaw law, double young, double poisson, double density) {
  if (!(young > 0)) throw std::invalid_argument("Young's modulus must be > 0 Pa");
  if (!(poisson > -1 && poisson < 0.5)) throw std::invalid_argument("Poisson ratio must lie in (-1, 0.5)");
  if (!(density >= 0)) throw std::invalid_argument("density must be >= 0 kg/m^3");
  Material m;
  m.law = law;
  m.mu = young / (2 * (1 + poisson));
  m.lambda = young * poisson / ((1 + poisson) * (1 - 2 * poisson));
  m.density = density;
  return m;
}

const char* to_string(MaterialLaw law) { return law == MaterialLaw::stvk ? "stvk" : "neo_hookean"; }

}  // namespace fascia
