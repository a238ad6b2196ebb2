// The resident memory of a process, for the runtime benchmarks.
#pragma once

#include <sys/types.h>

#include <fstream>
#include <string>

namespace dome::bench {

// VmRSS of process `pid` from /proc, MiB; -1 when it cannot be read.
inline double ProcessRssMb(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string key;
  while (in >> key) {
    if (key == "VmRSS:") {
      double kb = 0;
      in >> kb;
      return kb / 1024.0;
    }
    std::string rest;
    std::getline(in, rest);
  }
  return -1;
}

}  // namespace dome::bench
