// `dome stereo TAKE [--camera ID] [--instant TC] [--options FILE] --out DIR`:
// multi-baseline stereo (pipeline/stages.h Stereo: full range, or coarse to fine with
// a "coarse_to_fine" block) for one or every reference camera and instant; the output
// layout is in common/stereo/take_stereo.h. Options come from the profile (--profile),
// then the JSON file (pipeline/settings.h), then the flags given on the command line.
#include <cstdio>
#include <memory>
#include <string>

#include "cli/commands.h"
#include "cli/setting_flags.h"
#include "io/file_util.h"
#include "pipeline/stages.h"
#include "schema/json.h"

namespace dome::cli {

void AddStereoCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand(
      "stereo", "Multi-baseline stereo: depth maps (float TIFF, mm) per reference camera");
  struct Args {
    std::string take, camera, instant, out, options_file, profile = "default";
    int threads = 0;
    bool no_preview = false;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("TAKE", a->take, "take folder")->required();
  cmd->add_option("--out", a->out, "output folder (DIR/<instant>/depth/<camera>.tiff, ...)")
      ->required();
  cmd->add_option("--camera", a->camera, "reference camera id (default: every camera)");
  cmd->add_option("--instant", a->instant, "instant HH-MM-SS-FF (default: every instant)");
  cmd->add_option("--profile", a->profile,
                  "starting options: default (synthetic dome) or real (photographs: stricter "
                  "uniqueness, windows 9 and 13)")
      ->check(CLI::IsMember({"default", "real"}))
      ->capture_default_str();
  cmd->add_option("--options", a->options_file,
                  "stereo options as JSON (dome.runtime.StereoSettings, a \"coarse_to_fine\" "
                  "block included; flags override it)");
  auto flags = std::make_shared<SettingFlags<stereo::TakeStereoOptions>>(
      cmd, pipeline::StereoSettingFields());
  cmd->add_option("--threads", a->threads, "threads (0 = all)")->capture_default_str();
  cmd->add_flag("--no-preview", a->no_preview, "do not write preview PNGs");
  cmd->callback([=] {
    runtime::StereoSettings settings;
    const std::string where = a->options_file.empty() ? "stereo options" : a->options_file;
    if (!a->options_file.empty()) {
      schema::ParseJson(io::ReadFileBytes(a->options_file), where, "not a stereo options object",
                        &settings);
    }
    flags->Apply(&settings);
    stereo::TakeStereoOptions base;
    if (a->profile == "real") base.stereo = stereo::RealImageOptions();
    stereo::TakeStereoOptions options = pipeline::FromStereoSettings(settings, where, base);
    options.stereo.num_threads = a->threads;
    options.write_previews = !a->no_preview;
    const auto results = pipeline::RunTakeStereo(a->take, a->camera, a->instant, a->out, options);
    for (const auto& r : results) std::fputs(r.BriefReport().c_str(), stdout);
    *exit_code = 0;
  });
}

}  // namespace dome::cli
