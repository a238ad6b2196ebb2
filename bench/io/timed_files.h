// What the benches of bench/io share: the files named on the command line with
// `--repeats N`, and the milliseconds of timed runs.
#pragma once

#include <chrono>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "eval/statistics.h"

namespace dome::bench {

struct TimedFiles {
  std::vector<std::string> paths;
  int repeats = 0;  // timed runs per file and variant
};

// Parses `FILE... [--repeats N]` (N a positive count, `default_repeats` when absent).
// False, with `usage` and what was wrong on stderr, when no file is named or N is not a
// positive count.
inline bool ParseTimedFiles(int argc, char** argv, int default_repeats, const char* usage,
                            TimedFiles* out) {
  out->repeats = default_repeats;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a != "--repeats") {
      out->paths.push_back(a);
      continue;
    }
    size_t used = 0;
    int n = 0;
    try {
      if (i + 1 < argc) n = std::stoi(argv[i + 1], &used);
    } catch (const std::exception&) {
      n = 0;
    }
    if (i + 1 >= argc || used != std::string(argv[i + 1]).size() || n < 1) {
      std::fprintf(stderr, "--repeats: expected a positive count, got '%s'\n%s\n",
                   i + 1 < argc ? argv[i + 1] : "", usage);
      return false;
    }
    out->repeats = n;
    ++i;
  }
  if (out->paths.empty()) std::fprintf(stderr, "%s\n", usage);
  return !out->paths.empty();
}

inline double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// The median of timed runs (eval::Quantile's: interpolated for an even count).
inline double MedianMs(std::vector<double> ms) { return eval::Quantile(ms, 0.5); }

// A bench's main: run(argc, argv), an exception printed as "NAME: what" and exit code 1.
inline int GuardedMain(const char* name, int (*run)(int, char**), int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", name, e.what());
    return 1;
  }
}

}  // namespace dome::bench
