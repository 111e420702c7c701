// fascia schema: the JSON Schema of the scene language, generated from the parameter registry.
#include "commands.hpp"

#include "dsl/schema.hpp"

#include <iostream>
#include <memory>

namespace fascia::app {

void register_schema(CLI::App& app, Action& action) {
  CLI::App* cmd = app.add_subcommand("schema", "Print the JSON Schema (draft-07) of the scene language");
  auto markdown = std::make_shared<bool>(false);
  cmd->add_flag("--markdown", *markdown, "Print the parameter reference as a Markdown table instead");
  cmd->callback([&action, markdown] {
    action = [markdown] {
      if (*markdown)
        std::cout << dsl::registry_markdown();
      else
        std::cout << dsl::scene_json_schema().dump(2) << "\n";
      return kOk;
    };
  });
}

}  // namespace fascia::app
