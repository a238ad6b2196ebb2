#include "cli/app.h"

#include <CLI/CLI.hpp>
#include <cstdio>
#include <string>

#include "core/error.h"
#include "core/logging.h"

namespace dome::cli {

int RunDome(int argc, char** argv) {
  CLI::App app{"dome: 3D structure of moving scenes from many synchronized cameras"};
  app.require_subcommand(1);
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error or off");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    core::SetUpLogging(log_level);
    return 0;
  } catch (const core::InputError& e) {
    std::fprintf(stderr, "dome: %s\n", e.what());
    return 1;
  }
}

}  // namespace dome::cli
