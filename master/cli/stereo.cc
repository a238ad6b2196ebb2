// `dome stereo TAKE [--camera ID] [--instant TC] --out DIR`: multi-baseline stereo
// (common/stereo/multi_baseline.h) for one or every reference camera and instant;
// the output layout is in common/stereo/take_stereo.h.
#include <cstdio>
#include <memory>
#include <string>

#include "cli/commands.h"
#include "stereo/take_stereo.h"

namespace dome::cli {

void AddStereoCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand(
      "stereo", "Multi-baseline stereo: depth maps (float TIFF, mm) per reference camera");
  struct Args {
    std::string take, camera, instant, out;
    stereo::TakeStereoOptions options;
    bool no_preview = false;
  };
  auto a = std::make_shared<Args>();
  auto& s = a->options.stereo;
  cmd->add_option("TAKE", a->take, "take folder")->required();
  cmd->add_option("--out", a->out, "output folder (DIR/<instant>/depth/<camera>.tiff, ...)")
      ->required();
  cmd->add_option("--camera", a->camera, "reference camera id (default: every camera)");
  cmd->add_option("--instant", a->instant, "instant HH-MM-SS-FF (default: every instant)");
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
  cmd->add_option("--min-curvature", s.min_curvature, "grey^2 per level^2 per sample")
      ->capture_default_str();
  cmd->add_option("--min-uniqueness", s.min_uniqueness, "second-best margin over the best")
      ->capture_default_str();
  cmd->add_option("--min-texture", s.min_texture_grey, "reference window grey std-dev")
      ->capture_default_str();
  cmd->add_option("--max-neighbours", a->options.cluster.max_neighbours,
                  "cluster size without the reference, when rig.json names none")
      ->capture_default_str();
  cmd->add_option("--threads", s.num_threads, "threads (0 = all)")->capture_default_str();
  cmd->add_flag("--no-preview", a->no_preview, "do not write preview PNGs");
  cmd->callback([=] {
    stereo::TakeStereoOptions options = a->options;
    options.write_previews = !a->no_preview;
    const auto results = stereo::RunTakeStereo(a->take, a->camera, a->instant, a->out, options);
    for (const auto& r : results) std::fputs(r.BriefReport().c_str(), stdout);
    *exit_code = 0;
  });
}

}  // namespace dome::cli
