// The command line's numeric checks: what they take, and refusals that say what is expected.
#include "number_checks.hpp"

#include <catch2/catch.hpp>

#include <string>

using namespace fascia::app;

namespace {

std::string refusal(const CLI::Validator& check, std::string text) { return check(text); }

}  // namespace

TEST_CASE("numeric options take numbers in their range and name what they expect otherwise", "[app]") {
  for (const char* ok : {"1", "0.5", "16", "1e3"}) {
    CHECK(refusal(kPositiveNumber, ok).empty());
    CHECK(refusal(kNonNegativeNumber, ok).empty());
  }
  CHECK(refusal(kNonNegativeNumber, "0").empty());
  CHECK(refusal(kPositiveNumber, "0") == "expected a number > 0, got 0");
  CHECK(refusal(kNonNegativeNumber, "-1") == "expected a number >= 0, got -1");
  for (const char* bad : {"", "abc", "2x", "nan", "inf", "-inf"}) {
    CAPTURE(bad);
    CHECK(refusal(kPositiveNumber, bad) == std::string("expected a number > 0, got ") + bad);
    CHECK(refusal(kNonNegativeNumber, bad) == std::string("expected a number >= 0, got ") + bad);
  }
}

TEST_CASE("a refused numeric option is reported with the option's name", "[app]") {
  CLI::App app;
  int threads = 0;
  app.add_option("--threads", threads)->check(kNonNegativeNumber);
  try {
    app.parse(std::vector<std::string>{"-1", "--threads"});
    FAIL("a negative count was accepted");
  } catch (const CLI::ValidationError& e) {
    CHECK(std::string(e.what()) == "--threads: expected a number >= 0, got -1");
  }
}
