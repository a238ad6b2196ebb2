// `dome info TAKE`: validate a take and print its summary.
#include <cstdio>
#include <string>

#include "cli/commands.h"
#include "take/validate.h"

namespace dome::cli {

void AddInfoCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand("info", "Validate a take folder and print a summary");
  auto take_dir = std::make_shared<std::string>();
  auto quick = std::make_shared<bool>(false);
  cmd->add_option("TAKE", *take_dir, "take folder")->required();
  cmd->add_flag("--quick", *quick, "check that images exist without decoding them");
  cmd->callback([=] {
    take::ValidateOptions options;
    options.decode_images = !*quick;
    const take::TakeReport report = take::ValidateTake(*take_dir, options);
    std::fputs(report.Summary().c_str(), report.ok() ? stdout : stderr);
    *exit_code = report.ok() ? 0 : 1;
  });
}

}  // namespace dome::cli
