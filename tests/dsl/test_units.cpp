#include "dsl/units.hpp"

#include <catch2/catch.hpp>

using namespace fascia::dsl;

TEST_CASE("quantities convert to SI", "[dsl][units]") {
  struct Case {
    const char* text;
    double si;
    Dimension dimension;
  };
  const Case cases[] = {
      {"40 kPa", 40e3, dim::pressure},       {"40kPa", 40e3, dim::pressure},
      {"3 mm", 3e-3, dim::length},           {"10 ms", 1e-2, dim::time},
      {"1000 kg/m^3", 1000, dim::density},   {"1 g/cm^3", 1000, dim::density},
      {"-9.81 m/s^2", -9.81, dim::acceleration}, {"2 min", 120, dim::time},
      {"5 N", 5, dim::force},                {"1.5 MPa", 1.5e6, dim::pressure},
      {"2 N/m^2", 2, dim::pressure},         {"3 N*m", 3, Dimension{1, 2, -2}},
      {"0.3", 0.3, dim::none},               {"1e-6", 1e-6, dim::none},
      {"20 mm/s", 0.02, dim::velocity},      {"2 1/s", 2, dim::frequency},
      {"4 Hz", 4, dim::frequency},           {"7 um", 7e-6, dim::length},
  };
  for (const Case& c : cases) {
    INFO(c.text);
    std::string error;
    const auto q = parse_quantity(c.text, error);
    REQUIRE(q.has_value());
    CHECK(q->value == Approx(c.si).epsilon(1e-12));
    CHECK(q->dimension == c.dimension);
  }
  std::string error;
  const auto deg = parse_quantity("90 deg", error);
  REQUIRE(deg);
  CHECK(deg->value == Approx(3.14159265358979 / 2));
}

TEST_CASE("bad quantities are refused with a reason", "[dsl][units]") {
  std::string error;
  CHECK_FALSE(parse_quantity("kPa", error));
  CHECK_THAT(error, Catch::Contains("not a number"));
  CHECK_FALSE(parse_quantity("3 kPaa", error));
  CHECK_THAT(error, Catch::Contains("unknown unit 'kPaa'"));
  CHECK_FALSE(parse_quantity("3 m/", error));
  CHECK_FALSE(parse_quantity("inf", error));
  CHECK_FALSE(parse_quantity("3 m^", error));
  CHECK_FALSE(parse_quantity("", error));
}

TEST_CASE("SI units are named for messages", "[dsl][units]") {
  CHECK(si_unit(dim::pressure) == "Pa");
  CHECK(si_unit(dim::acceleration) == "m/s^2");
  CHECK(si_unit(dim::velocity) == "m/s");
  CHECK(dimension_name(dim::density) == "density");
  CHECK(format_si(40000, dim::pressure) == "40000 Pa");
}
