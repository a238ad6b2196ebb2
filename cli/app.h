// The `dome` command-line client: one CLI11 app with a subcommand per tool. Each
// subcommand lives in its own file (info.cc, import.cc, eval.cc, ...) and registers
// itself in BuildApp(); the work is done by library functions.
#pragma once

namespace dome::cli {

// Runs `dome` with the given arguments; returns the process exit code. Errors in
// the input are printed as "dome: <where>: <what>" and give exit code 1.
int RunDome(int argc, char** argv);

}  // namespace dome::cli
