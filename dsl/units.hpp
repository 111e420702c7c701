// Physical quantities with units in scene files: `40 kPa`, `3 mm`, `10 ms`, `1000 kg/m^3`.
// A bare number is in SI units. Values are converted to SI on reading.
#pragma once

#include <optional>
#include <string>

namespace fascia::dsl {

// Exponents of the SI base units kg, m, s (enough for mechanics). Angles are dimensionless.
struct Dimension {
  int kg = 0;
  int m = 0;
  int s = 0;

  bool operator==(const Dimension& o) const { return kg == o.kg && m == o.m && s == o.s; }
  bool operator!=(const Dimension& o) const { return !(*this == o); }
};

namespace dim {
constexpr Dimension none{0, 0, 0};
constexpr Dimension length{0, 1, 0};
constexpr Dimension time{0, 0, 1};
constexpr Dimension mass{1, 0, 0};
constexpr Dimension pressure{1, -1, -2};  // Pa = N/m^2 (stress, Young's modulus, traction)
constexpr Dimension density{1, -3, 0};    // kg/m^3
constexpr Dimension acceleration{0, 1, -2};
constexpr Dimension velocity{0, 1, -1};
constexpr Dimension force{1, 1, -2};
constexpr Dimension frequency{0, 0, -1};  // 1/s (Rayleigh mass damping)
}  // namespace dim

// Name of the quantity ("pressure") and its SI unit ("Pa"), for messages and the JSON Schema.
std::string dimension_name(const Dimension& d);
std::string si_unit(const Dimension& d);

struct Quantity {
  double value = 0;  // SI
  Dimension dimension;
  bool bare = false;  // a number without unit: SI in whatever dimension is expected
};

// Parses a unit expression: products and quotients of units with optional integer powers, e.g.
// "kPa", "kg/m^3", "m/s^2", "N*m", "mm". Units: m, s, g, N, Pa, J, Hz with SI prefixes
// (n u µ m c k M G), plus kg, min, h, rad, deg. Returns the factor to SI and the dimension, or
// nullopt with `error` set.
std::optional<Quantity> parse_unit(const std::string& text, std::string& error);

// Parses "number [unit]". Returns nullopt with `error` set when the text is not a number
// optionally followed by a unit.
std::optional<Quantity> parse_quantity(const std::string& text, std::string& error);

// Formats an SI value with its SI unit: "40000 Pa", "0.01 s", "0.3".
std::string format_si(double value, const Dimension& d);

}  // namespace fascia::dsl
