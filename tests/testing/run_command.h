// Test helper: run one of dome's executables as a user would and capture what it
// prints (stdout and stderr together) and its exit code.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace dome::testing {

struct CommandResult {
  int exit_code = -1;  // -1 when the process did not exit normally
  std::string output;  // stdout and stderr together
};

// Runs build/bin/<binary> with `args` (a shell-quoted string).
inline CommandResult RunDomeBinary(const std::string& args, const std::string& binary = "dome") {
  const std::string command =
      std::string(DOME_BINARY_DIR) + "/bin/" + binary + " " + args + " 2>&1";
  CommandResult result;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return result;
  std::array<char, 4096> buffer;
  size_t n;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) {
    result.output.append(buffer.data(), n);
  }
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

}  // namespace dome::testing
