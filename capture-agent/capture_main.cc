// dome-capture: drives one VCR + digitizer through rewind-play passes. Not in this
// build yet; the executable exists so deployment scripts can rely on it.
#include <CLI/CLI.hpp>
#include <cstdio>

int main(int argc, char** argv) {
  CLI::App app{"dome-capture: digitizes VITC-tagged frames from a tape and publishes them"};
  std::string camera;
  app.add_option("--camera", camera, "camera id recorded on this tape");
  CLI11_PARSE(app, argc, argv);
  std::fprintf(stderr, "dome-capture: capture is not available in this build\n");
  return 2;
}
