#include "dsl/registry.hpp"
#include "dsl/schema.hpp"

#include <catch2/catch.hpp>

using namespace fascia::dsl;

namespace {

void check_docs(const ParamSpec& spec, const std::string& path) {
  INFO(path);
  CHECK_FALSE(spec.doc.empty());
  for (const ParamSpec& c : spec.children) check_docs(c, path + "." + c.name);
}

}  // namespace

TEST_CASE("every registry entry has a doc line", "[dsl][schema]") { check_docs(scene_registry(), "scene"); }

TEST_CASE("the JSON Schema follows the registry", "[dsl][schema]") {
  const nlohmann::json s = scene_json_schema();
  CHECK(s["$schema"] == "http://json-schema.org/draft-07/schema#");
  CHECK(s["type"] == "object");
  CHECK(s["additionalProperties"] == false);
  const auto& material = s["properties"]["materials"]["additionalProperties"];
  CHECK(material["required"] == nlohmann::json::array({"young"}));
  CHECK_THAT(material["properties"]["young"]["description"].get<std::string>(), Catch::Contains("Pa"));
  CHECK(material["properties"]["law"]["enum"] == nlohmann::json::array({"stvk", "neo_hookean", "hgo"}));
  CHECK(material["properties"]["poisson"]["exclusiveMaximum"] == 0.5);
  CHECK(material["properties"]["poisson"]["default"] == 0.3);
  const auto& load = s["properties"]["loads"]["items"];
  CHECK(load["maxProperties"] == 1);
  CHECK(s["properties"]["solver"]["properties"]["dt"]["anyOf"].size() == 2);
}
