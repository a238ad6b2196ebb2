// `dome stereo TAKE [--camera ID] [--instant TC] [--options FILE] --out DIR`:
// multi-baseline stereo (common/stereo/multi_baseline.h) for one or every reference
// camera and instant; the output layout is in common/stereo/take_stereo.h. Options come
// from the profile (--profile), then the JSON file (common/stereo/options_json.h), then
// the flags given on the command line.
#include <cstdio>
#include <memory>
#include <string>

#include "cli/commands.h"
#include "stereo/options_json.h"
#include "stereo/take_stereo.h"

namespace dome::cli {

void AddStereoCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand(
      "stereo", "Multi-baseline stereo: depth maps (float TIFF, mm) per reference camera");
  struct Args {
    std::string take, camera, instant, out, options_file, profile = "default";
    stereo::TakeStereoOptions options;
    bool no_preview = false;
    bool exact_warp = false;
  };
  auto a = std::make_shared<Args>();
  auto& s = a->options.stereo;
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
                  "stereo options as JSON (dome.runtime.StereoSettings; flags override it)");
  cmd->add_option("--z-min", s.z_min_mm, "nearest depth, mm")->capture_default_str();
  cmd->add_option("--z-max", s.z_max_mm, "farthest depth, mm")->capture_default_str();
  cmd->add_option("--levels", s.num_levels, "depth levels (0 = from the geometry)")
      ->capture_default_str();
  cmd->add_option("--level-step", s.level_step_px,
                  "parallax per level in the widest-baseline neighbour, px")
      ->capture_default_str();
  cmd->add_option("--windows", s.window_sizes_px,
                  "SSD window sides, px (odd; one range image each)")
      ->capture_default_str();
  cmd->add_flag("--normalize-contrast", s.normalize_contrast,
                "stretch each image's 1st..99th grey percentile to 0..255 (dark images)");
  cmd->add_flag("--sqrt-greys", s.sqrt_greys,
                "match the square roots of the greys (shot noise levelled; dim images)");
  cmd->add_option("--min-curvature", s.min_curvature, "grey^2 per level^2 per sample")
      ->capture_default_str();
  cmd->add_option("--min-uniqueness", s.min_uniqueness, "second-best margin over the best")
      ->capture_default_str();
  cmd->add_option("--min-texture", s.min_texture_grey, "reference window grey std-dev")
      ->capture_default_str();
  cmd->add_option("--speckle-area", s.speckle.min_area_px,
                  "drop depth pieces of fewer pixels (0 = keep all; stereo/speckle.h)")
      ->capture_default_str();
  cmd->add_option("--speckle-step", s.speckle.max_step_mm,
                  "largest depth step within one piece, mm")
      ->capture_default_str();
  cmd->add_option("--max-neighbours", a->options.cluster.max_neighbours,
                  "cluster size without the reference, when rig.json names none")
      ->capture_default_str();
  cmd->add_option("--threads", s.num_threads, "threads (0 = all)")->capture_default_str();
  cmd->add_flag("--exact-warp", a->exact_warp,
                "warp the neighbours per pixel and level instead of pre-warping them once "
                "(slower; prewarp_neighbours false)");
  cmd->add_flag("--no-preview", a->no_preview, "do not write preview PNGs");
  cmd->callback([=] {
    stereo::TakeStereoOptions options = a->options;
    if (!a->options_file.empty() || a->profile != "default") {
      // The profile, then the file over it, then every flag that was given.
      stereo::TakeStereoOptions base;
      if (a->profile == "real") base.stereo = stereo::RealImageOptions();
      options =
          a->options_file.empty() ? base : stereo::ReadStereoOptionsJson(a->options_file, base);
      const auto& f = a->options;
      auto given = [&](const char* flag) { return cmd->count(flag) > 0; };
      if (given("--z-min")) options.stereo.z_min_mm = f.stereo.z_min_mm;
      if (given("--z-max")) options.stereo.z_max_mm = f.stereo.z_max_mm;
      if (given("--levels")) options.stereo.num_levels = f.stereo.num_levels;
      if (given("--level-step")) options.stereo.level_step_px = f.stereo.level_step_px;
      if (given("--windows")) options.stereo.window_sizes_px = f.stereo.window_sizes_px;
      if (given("--normalize-contrast")) options.stereo.normalize_contrast = true;
      if (given("--sqrt-greys")) options.stereo.sqrt_greys = true;
      if (given("--min-curvature")) options.stereo.min_curvature = f.stereo.min_curvature;
      if (given("--min-uniqueness")) options.stereo.min_uniqueness = f.stereo.min_uniqueness;
      if (given("--min-texture")) options.stereo.min_texture_grey = f.stereo.min_texture_grey;
      if (given("--speckle-area"))
        options.stereo.speckle.min_area_px = f.stereo.speckle.min_area_px;
      if (given("--speckle-step"))
        options.stereo.speckle.max_step_mm = f.stereo.speckle.max_step_mm;
      if (given("--max-neighbours")) options.cluster.max_neighbours = f.cluster.max_neighbours;
      if (given("--threads")) options.stereo.num_threads = f.stereo.num_threads;
    }
    if (a->exact_warp) options.stereo.prewarp_neighbours = false;
    options.write_previews = !a->no_preview;
    const auto results = stereo::RunTakeStereo(a->take, a->camera, a->instant, a->out, options);
    for (const auto& r : results) std::fputs(r.BriefReport().c_str(), stdout);
    *exit_code = 0;
  });
}

}  // namespace dome::cli
