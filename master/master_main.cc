// dome-master: the scheduler daemon. The distributed runtime is not in this build
// yet; the executable exists so deployment scripts and packaging can rely on it.
#include <CLI/CLI.hpp>
#include <cstdio>

int main(int argc, char** argv) {
  CLI::App app{"dome-master: schedules stereo and fusion jobs to dome-workers over ZeroMQ"};
  std::string workers = "tcp://*:5555";
  app.add_option("--workers", workers, "ROUTER endpoint workers connect to");
  CLI11_PARSE(app, argc, argv);
  std::fprintf(stderr, "dome-master: the distributed runtime is not available in this build\n");
  return 2;
}
