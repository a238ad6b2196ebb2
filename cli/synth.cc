// `dome synth --preset paper|small --out TAKE`: write a synthetic 3D Dome take with
// ground truth (common/synth/synth.h).
#include "synth/synth.h"

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "cli/commands.h"
#include "core/error.h"

namespace dome::cli {

void AddSynthCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand(
      "synth", "Render a synthetic dome take (cameras, images, tapes, truth, calibration)");
  struct Args {
    synth::SynthOptions options;
    std::string out;
    int cameras = 0, instants = 0, width = 0, height = 0;
    int64_t seed = 1;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--preset", args->options.preset,
                  "paper (the seed's 51 cameras, 11 instants, "
                  "320x245) or small (6 cameras, 3 instants, 160x120)")
      ->capture_default_str();
  cmd->add_option("--out", args->out, "take folder to write")->required();
  cmd->add_option("--seed", args->seed, "sensor-noise seed >= 0 (changes the noise only)")
      ->capture_default_str();
  auto* cameras =
      cmd->add_option("--cameras", args->cameras, "number of cameras (overrides the preset)");
  auto* instants = cmd->add_option("--instants", args->instants,
                                   "number of instants, 6 Hz (overrides the preset)");
  auto* width =
      cmd->add_option("--width", args->width, "take image width in pixels (overrides the preset)");
  auto* height = cmd->add_option("--height", args->height,
                                 "take image height in pixels (overrides the preset)");
  cmd->add_option("--threads", args->options.threads, "worker threads (0 = all)")
      ->capture_default_str();
  cmd->add_flag("--overwrite", args->options.overwrite, "replace an existing take");
  cmd->add_flag("!--no-tape", args->options.write_tape, "do not write tape/ (interlaced frames)");
  cmd->add_flag(
      "--tape-video", args->options.write_tape_video,
      "also write tape/<camera>.avi: lossless interlaced frames with VITC, for dome-capture");
  cmd->add_flag("!--no-calib", args->options.write_calibration, "do not write calib/");
  cmd->add_flag("!--no-background", args->options.write_background,
                "do not write background/ (plates of the dome without the person)");
  cmd->callback([=] {
    synth::SynthOptions options = args->options;
    core::Require(args->seed >= 0, "--seed",
                  "expected a seed >= 0, got " + std::to_string(args->seed));
    options.seed = static_cast<uint64_t>(args->seed);
    if (cameras->count() > 0) options.cameras = args->cameras;
    if (instants->count() > 0) options.instants = args->instants;
    if (width->count() > 0) options.width_px = args->width;
    if (height->count() > 0) options.height_px = args->height;
    const synth::SynthSummary summary = synth::GenerateTake(options, args->out);
    std::fputs(summary.BriefReport().c_str(), stdout);
    *exit_code = 0;
  });
}

}  // namespace dome::cli
