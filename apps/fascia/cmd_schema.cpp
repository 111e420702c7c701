// fascia schema: the JSON Schema of the scene language, generated from the parameter registry.
#include "commands.hpp"

#include "dsl/schema.hpp"

#include <iostream>

namespace fascia::app {

void register_schema(CLI::App& app, Action& action) {
  CLI::App* cmd = app.add_subcommand("schema", "Print the JSON Schema (draft-07) of the scene language");
  cmd->callback([&action] {
    action = [] {
      std::cout << dsl::scene_json_schema().dump(2) << "\n";
      return kOk;
    };
  });
}

}  // namespace fascia::app
