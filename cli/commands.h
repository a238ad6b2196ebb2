// Subcommands of `dome`. Each Add*Command registers one CLI11 subcommand whose
// callback does the work through library calls and stores the process exit code in
// *exit_code. Callbacks throw core::InputError for bad input; RunDome prints it.
#pragma once

#include <CLI/CLI.hpp>

namespace dome::cli {

void AddInfoCommand(CLI::App* app, int* exit_code);
void AddImportCommand(CLI::App* app, int* exit_code);
void AddEvalCommand(CLI::App* app, int* exit_code);
void AddSynthCommand(CLI::App* app, int* exit_code);
void AddCalibrateCommand(CLI::App* app, int* exit_code);
void AddStereoCommand(CLI::App* app, int* exit_code);
void AddFuseCommand(CLI::App* app, int* exit_code);
void AddMasksCommand(CLI::App* app, int* exit_code);
void AddMeshCommand(CLI::App* app, int* exit_code);

void AddRunCommand(CLI::App* app, int* exit_code);
void AddSubmitCommand(CLI::App* app, int* exit_code);
void AddStatusCommand(CLI::App* app, int* exit_code);
void AddWatchCommand(CLI::App* app, int* exit_code);
void AddCancelCommand(CLI::App* app, int* exit_code);
void AddListCommand(CLI::App* app, int* exit_code);
void AddViewCommand(CLI::App* app, int* exit_code);
void AddExportCommand(CLI::App* app, int* exit_code);
void AddKeygenCommand(CLI::App* app, int* exit_code);

}  // namespace dome::cli
