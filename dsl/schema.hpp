// JSON Schema (draft-07) of the scene language, generated from the parameter registry, for YAML
// editors (e.g. the YAML language server's `# yaml-language-server: $schema=...`).
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace fascia::dsl {

nlohmann::json scene_json_schema();

// The registry as a Markdown table (key path, type, unit, range, default, doc), for docs/.
std::string registry_markdown();

}  // namespace fascia::dsl
