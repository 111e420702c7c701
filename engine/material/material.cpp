#include "material/material.hpp"

#include <cmath>
#include <stdexcept>

namespace fascia {

namespace {
// pi / 2 and the rounding of '90 deg' converted to radians (a few ulps).
constexpr double kRightAngle = 1.57079632679489661923, kAngleSlack = 1e-14;
}  // namespace

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
  Fibres& f = m.fibres;
  f.direction = (1 / n) * direction;
  f.axes[0] = f.axes[1] = f.direction;
  if (f.families == 2) {
    // e2: the part of the (unit) plane vector orthogonal to e1; its length is the sine of their
    // angle, and below 1e-6 (a degree's 2e-5th) the plane is not defined to double precision.
    const Vec3 e2 = f.plane - dot(f.plane, f.direction) * f.direction;
    const double s = norm(e2);
    if (!(s > 1e-6)) throw std::invalid_argument("the fibre plane vector is parallel to the fibre direction");
    const double c = std::cos(f.angle), sg = std::sin(f.angle);
    f.axes[0] = c * f.direction + (sg / s) * e2;
    f.axes[1] = c * f.direction - (sg / s) * e2;
  }
  return m;
}

Material make_hgo_material(double young, double poisson, double density, const Fibres& fibres,
                           HgoFormulation formulation) {
  if (!(fibres.k1 >= 0)) throw std::invalid_argument("fibre stiffness k1 must be >= 0 Pa");
  if (!(fibres.k2 > 0)) throw std::invalid_argument("fibre exponent k2 must be > 0");
  if (!(fibres.dispersion >= 0 && fibres.dispersion <= 1.0 / 3)) throw std::invalid_argument("fibre dispersion must lie in [0, 1/3]");
  if (fibres.families != 1 && fibres.families != 2) throw std::invalid_argument("fibre families must be 1 or 2");
  Material m = make_material(MaterialLaw::hgo, young, poisson, density);
  m.fibres = fibres;
  m.formulation = formulation;
  if (fibres.families == 2) {
    if (!(fibres.angle >= 0 && fibres.angle <= kRightAngle + kAngleSlack))
      throw std::invalid_argument("the fibre families' angle must lie in [0, 90 deg]");
    const double n = norm(fibres.plane);
    if (!(n > 0) || !std::isfinite(n)) throw std::invalid_argument("the fibre plane vector must be nonzero and finite");
    m.fibres.plane = (1 / n) * fibres.plane;
  }
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
