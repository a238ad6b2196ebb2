#include "cli/app.h"

#include <CLI/CLI.hpp>
#include <cstdio>
#include <string>

#include "cli/commands.h"
#include "core/error.h"
#include "core/logging.h"
#include "core/memory.h"

namespace dome::cli {

int RunDome(int argc, char** argv) {
  core::RetainFreedMemory();
  core::ChoosePageSize();
  CLI::App app{"dome: 3D structure of moving scenes from many synchronized cameras"};
  // At most one command; none prints the help. (Requiring one would make CLI11 report
  // a missing command instead of naming the unknown word the user typed.)
  app.require_subcommand(0, 1);
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error or off");
  app.parse_complete_callback([&] { core::SetUpLogging(log_level); });
  int exit_code = 0;
  AddInfoCommand(&app, &exit_code);
  AddImportCommand(&app, &exit_code);
  AddEvalCommand(&app, &exit_code);
  AddSynthCommand(&app, &exit_code);
  AddCalibrateCommand(&app, &exit_code);
  AddMasksCommand(&app, &exit_code);
  AddStereoCommand(&app, &exit_code);
  AddFuseCommand(&app, &exit_code);
  AddMeshCommand(&app, &exit_code);
  AddRunCommand(&app, &exit_code);
  AddSubmitCommand(&app, &exit_code);
  AddStatusCommand(&app, &exit_code);
  AddWatchCommand(&app, &exit_code);
  AddCancelCommand(&app, &exit_code);
  AddListCommand(&app, &exit_code);
  AddViewCommand(&app, &exit_code);
  AddExportCommand(&app, &exit_code);
  AddKeygenCommand(&app, &exit_code);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const core::InputError& e) {
    std::fprintf(stderr, "dome: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dome: error: %s\n", e.what());
    return 1;
  }
  if (app.get_subcommands().empty()) {
    std::fputs(app.help().c_str(), stderr);
    return 1;
  }
  return exit_code;
}

}  // namespace dome::cli
