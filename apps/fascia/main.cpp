// fascia: frame-based simulation of connective tissues from the command line.
#include "commands.hpp"
#include "solve/blas_core.hpp"
#include "unexpected_error.hpp"

#include <iostream>

int main(int argc, char** argv) {
  // Before any BLAS call: OpenBLAS's kernels for this CPU where its detection fell back to generic ones.
  fascia::select_blas_core();
  fascia::app::install_terminate_handler();
  CLI::App app{"fascia " FASCIA_VERSION " - frame-based simulation of connective tissues"};
  app.set_version_flag("--version", "fascia " FASCIA_VERSION);
  app.require_subcommand(1);
  fascia::app::Action action;
  fascia::app::register_run(app, action);
  fascia::app::register_check(app, action);
  fascia::app::register_info(app, action);
  fascia::app::register_schema(app, action);
  fascia::app::register_study(app, action);
  fascia::app::register_bench(app, action);
  fascia::app::register_render(app, action);
  fascia::app::register_sweep(app, action);
  fascia::app::register_collect(app, action);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : fascia::app::kUsage;
  }
  try {
    return action ? action() : fascia::app::kUsage;
  } catch (...) {
    const fascia::app::Failure failure = fascia::app::classify_unexpected(std::current_exception());
    std::cerr << failure.message << "\n";
    return failure.exit_code;
  }
}
