#include "dsl/units.hpp"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <vector>

namespace fascia::dsl {

namespace {

struct UnitDef {
  const char* name;
  double factor;
  Dimension dimension;
  bool prefixable;
};

const double kPi = 3.14159265358979323846;

const std::vector<UnitDef>& units() {
  static const std::vector<UnitDef> table = {
      {"m", 1.0, dim::length, true},       {"s", 1.0, dim::time, true},
      {"g", 1e-3, dim::mass, true},        {"kg", 1.0, dim::mass, false},
      {"N", 1.0, dim::force, true},        {"Pa", 1.0, dim::pressure, true},
      {"J", 1.0, {1, 2, -2}, true},        {"Hz", 1.0, dim::frequency, true},
      {"min", 60.0, dim::time, false},     {"h", 3600.0, dim::time, false},
      {"rad", 1.0, dim::none, false},      {"deg", kPi / 180.0, dim::none, false},
  };
  return table;
}

struct Prefix {
  const char* name;
  double factor;
};

const std::vector<Prefix>& prefixes() {
  static const std::vector<Prefix> table = {{"n", 1e-9}, {"u", 1e-6}, {"\xC2\xB5", 1e-6}, {"m", 1e-3},
                                            {"c", 1e-2}, {"k", 1e3},  {"M", 1e6},          {"G", 1e9}};
  return table;
}

std::optional<Quantity> lookup_unit(const std::string& name) {
  for (const UnitDef& u : units())
    if (name == u.name) return Quantity{u.factor, u.dimension};
  for (const Prefix& p : prefixes()) {
    const std::string pn = p.name;
    if (name.size() <= pn.size() || name.compare(0, pn.size(), pn) != 0) continue;
    const std::string rest = name.substr(pn.size());
    for (const UnitDef& u : units())
      if (u.prefixable && rest == u.name) return Quantity{p.factor * u.factor, u.dimension};
  }
  return std::nullopt;
}

std::string trim(const std::string& s) {
  std::size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

}  // namespace

std::string dimension_name(const Dimension& d) {
  if (d == dim::none) return "dimensionless number";
  if (d == dim::length) return "length";
  if (d == dim::time) return "time";
  if (d == dim::mass) return "mass";
  if (d == dim::pressure) return "pressure";
  if (d == dim::density) return "density";
  if (d == dim::acceleration) return "acceleration";
  if (d == dim::velocity) return "velocity";
  if (d == dim::force) return "force";
  if (d == dim::frequency) return "frequency";
  return "quantity in " + si_unit(d);
}

std::string si_unit(const Dimension& d) {
  if (d == dim::none) return "";
  if (d == dim::pressure) return "Pa";
  if (d == dim::force) return "N";
  if (d == dim::density) return "kg/m^3";
  if (d == dim::frequency) return "1/s";
  std::string num, den;
  auto add = [&](const char* name, int power) {
    if (power == 0) return;
    std::string& target = power > 0 ? num : den;
    if (!target.empty()) target += "*";
    target += name;
    if (std::abs(power) != 1) target += "^" + std::to_string(std::abs(power));
  };
  add("kg", d.kg);
  add("m", d.m);
  add("s", d.s);
  if (num.empty()) num = "1";
  return den.empty() ? num : num + "/" + den;
}

std::optional<Quantity> parse_unit(const std::string& text_in, std::string& error) {
  const std::string text = trim(text_in);
  if (text.empty()) return Quantity{1.0, dim::none};
  Quantity result{1.0, dim::none};
  std::size_t i = 0;
  int sign = +1;  // +1 multiply, -1 divide the next factor
  bool expect_factor = true;
  while (i < text.size()) {
    const char c = text[i];
    if (std::isspace(static_cast<unsigned char>(c))) {
      ++i;
      continue;
    }
    if (c == '*' || c == '/') {
      if (expect_factor) {
        error = "unit '" + text + "' has a misplaced '" + std::string(1, c) + "'";
        return std::nullopt;
      }
      sign = c == '/' ? -1 : +1;
      expect_factor = true;
      ++i;
      continue;
    }
    // A factor: "1" (as in 1/s) or a unit name, then optional ^power.
    std::size_t j = i;
    while (j < text.size() && (std::isalpha(static_cast<unsigned char>(text[j])) || text[j] == '1' ||
                               static_cast<unsigned char>(text[j]) >= 0x80))
      ++j;
    if (j == i) {
      error = "unexpected '" + std::string(1, c) + "' in unit '" + text + "'";
      return std::nullopt;
    }
    if (!expect_factor) sign = +1;  // "N m" reads as N*m
    const std::string name = text.substr(i, j - i);
    std::optional<Quantity> u = name == "1" ? std::optional<Quantity>(Quantity{1.0, dim::none}) : lookup_unit(name);
    if (!u) {
      error = "unknown unit '" + name + "'";
      return std::nullopt;
    }
    int power = 1;
    if (j < text.size() && text[j] == '^') {
      std::size_t k = j + 1;
      if (k < text.size() && (text[k] == '-' || text[k] == '+')) ++k;
      std::size_t digits = k;
      while (digits < text.size() && std::isdigit(static_cast<unsigned char>(text[digits]))) ++digits;
      if (digits == k) {
        error = "unit '" + text + "': '^' must be followed by an integer power";
        return std::nullopt;
      }
      power = std::atoi(text.substr(j + 1, digits - j - 1).c_str());
      j = digits;
    }
    power *= sign;
    result.value *= std::pow(u->value, power);
    result.dimension.kg += power * u->dimension.kg;
    result.dimension.m += power * u->dimension.m;
    result.dimension.s += power * u->dimension.s;
    expect_factor = false;
    i = j;
  }
  if (expect_factor) {
    error = "unit '" + text + "' ends with an operator";
    return std::nullopt;
  }
  return result;
}

std::optional<Quantity> parse_quantity(const std::string& text_in, std::string& error) {
  const std::string text = trim(text_in);
  if (text.empty()) {
    error = "empty value";
    return std::nullopt;
  }
  const char* begin = text.c_str();
  char* end = nullptr;
  const double number = std::strtod(begin, &end);
  if (end == begin) {
    error = "'" + text + "' is not a number";
    return std::nullopt;
  }
  const std::string rest = text.substr(static_cast<std::size_t>(end - begin));
  // strtod accepts "inf", "nan" and hex; scene values must be finite decimals.
  if (!std::isfinite(number)) {
    error = "'" + text + "' is not a finite number";
    return std::nullopt;
  }
  std::optional<Quantity> unit = parse_unit(rest, error);
  if (!unit) return std::nullopt;
  return Quantity{number * unit->value, unit->dimension, trim(rest).empty()};
}

std::string format_si(double value, const Dimension& d) {
  std::ostringstream os;
  os.precision(12);
  os << value;
  const std::string u = si_unit(d);
  if (!u.empty()) os << " " << u;
  return os.str();
}

}  // namespace fascia::dsl
