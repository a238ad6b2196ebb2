// dome-worker: stateless job executor. The distributed runtime is not in this build
// yet; the executable exists so deployment scripts and packaging can rely on it.
#include <CLI/CLI.hpp>
#include <cstdio>

int main(int argc, char** argv) {
  CLI::App app{"dome-worker: runs stereo and fusion jobs for a dome-master"};
  std::string master;
  app.add_option("--master", master, "master endpoint, e.g. tcp://host:5555");
  CLI11_PARSE(app, argc, argv);
  std::fprintf(stderr, "dome-worker: the distributed runtime is not available in this build\n");
  return 2;
}
