#include "material/material.hpp"

#include <cmath>
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

Material with_fibre_direction(Material m, const Vec3& direction) {
  const double n = norm(direction);
  if (!(n > 0) || !std::isfinite(n)) throw std::invalid_argument("a fibre direction must be a nonzero finite vector");
  m.fibres.direction = (1 / n) * direction;
  return m;
}

Material make_hgo_material(double young, double poisson, double density, const Fibres& fibres) {
  if (!(fibres.k1 >= 0)) throw std::invalid_argument("fibre stiffness k1 must be >= 0 Pa");
  if (!(fibres.k2 > 0)) throw std::invalid_argument("fibre exponent k2 must be > 0");
  if (!(fibres.dispersion >= 0 && fibres.dispersion <= 1.0 / 3)) throw std::invalid_argument("fibre dispersion must lie in [0, 1/3]");
  Material m = make_material(MaterialLaw::hgo, young, poisson, density);
  m.fibres = fibres;
  return with_fibre_direction(m, fibres.direction);
}

const char* to_string(MaterialLaw law) {
  switch (law) {
    case MaterialLaw::stvk: return "stvk";
    case MaterialLaw::neo_hookean: return "neo_hookean";
    case MaterialLaw::hgo: return "hgo";
  }
  return "?";
}

}  // namespace fascia
