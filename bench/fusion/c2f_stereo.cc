// Stereo of every camera of a take at one instant, full-range or coarse to fine
// (pipeline/coarse_to_fine.h), for `dome fuse --depth-dir` (bench/fusion/robovision.sh
// STEREO=c2f):
//   c2f_stereo TAKE OUT --box X0 Y0 Z0 X1 Y1 Z1 [--full] [--window 17] [--uniqueness 0.1]
//              [--neighbours 2] [--factor 4] [--coarse-window 7] [--tile 64]
//              [--margin-levels 2] [--trim 0.02] [--min-coarse 1]
//              [--coarse-uniqueness 0] [--exact-warp] [--threads 0]
//              [--speckle-area 0 --speckle-step MM]
// The depth range of each camera is the nearest and farthest corner of the box (world
// mm) along its axis, +-2 mm. Contrast is normalised (the Robovision frames are dark).
// Writes OUT/<instant>/depth/<camera>.tiff (stereo/take_stereo.h layout) and prints one
// JSON line per camera (levels, density, seconds) and a total.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "core/timer.h"
#include "pipeline/coarse_to_fine.h"
#include "stereo/take_stereo.h"
#include "take/take.h"

using namespace dome;

namespace {
double CpuSeconds() { return double(std::clock()) / CLOCKS_PER_SEC; }
}  // namespace

int main(int argc, char** argv) {
  CLI::App app("Full-range or coarse-to-fine stereo of a take's cameras");
  std::string take_dir, out;
  std::vector<double> box;
  bool full = false;
  int window = 17, neighbours = 2, threads = 0;
  double uniqueness = 0.1;
  pipeline::CoarseToFineOptions c2f;
  app.add_option("TAKE", take_dir, "take folder")->required();
  app.add_option("OUT", out, "output folder")->required();
  app.add_option("--box", box, "world box x0 y0 z0 x1 y1 z1, mm")->expected(6)->required();
  app.add_flag("--full", full, "full-range search at full resolution");
  bool exact_warp = false;
  app.add_flag("--exact-warp", exact_warp, "the exact per-pixel warp (no pre-warped neighbours)");
  app.add_option("--window", window, "SSD window side, px")->capture_default_str();
  app.add_option("--uniqueness", uniqueness, "min_uniqueness")->capture_default_str();
  app.add_option("--neighbours", neighbours, "cameras per cluster")->capture_default_str();
  app.add_option("--factor", c2f.coarse_factor, "coarse reduction")->capture_default_str();
  app.add_option("--coarse-window", c2f.coarse_window_px, "coarse window, coarse px")
      ->capture_default_str();
  app.add_option("--tile", c2f.tile_px, "tile side, px")->capture_default_str();
  app.add_option("--margin-levels", c2f.margin_levels, "coarse levels around a tile's depths")
      ->capture_default_str();
  app.add_option("--trim", c2f.trim_fraction, "coarse depths dropped per end")
      ->capture_default_str();
  app.add_option("--min-coarse", c2f.min_coarse_depths, "coarse depths a tile needs")
      ->capture_default_str();
  app.add_option("--coarse-uniqueness", c2f.coarse_min_uniqueness,
                 "min_uniqueness of the coarse pass (0: --uniqueness)")
      ->capture_default_str();
  app.add_option("--fill", c2f.fill_min_neighbours,
                 "searched neighbour tiles that fill a tile without coarse depths (0: none)")
      ->capture_default_str();
  app.add_option("--threads", threads, "threads (0: all)")->capture_default_str();
  bool sqrt_greys = false;
  app.add_flag("--sqrt-greys", sqrt_greys, "match the square roots of the greys");
  stereo::SpeckleOptions speckle;
  app.add_option("--speckle-area", speckle.min_area_px, "drop depth pieces of fewer px (0: none)")
      ->capture_default_str();
  app.add_option("--speckle-step", speckle.max_step_mm, "largest step within a piece, mm")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  const take::Take take = take::OpenTake(take_dir);
  const std::string instant = take.instants.front();
  stereo::TakeStereoOptions options;
  options.stereo.window_sizes_px = {window};
  options.stereo.normalize_contrast = true;
  options.stereo.sqrt_greys = sqrt_greys;
  options.stereo.min_uniqueness = uniqueness;
  options.stereo.num_threads = threads;
  options.stereo.speckle = speckle;
  if (exact_warp) options.stereo.prewarp_neighbours = false;
  options.cluster.max_neighbours = neighbours;
  const double cpu0 = CpuSeconds();
  core::Stopwatch total;
  for (const auto& rc : take.rig.cameras) {
    const auto& cam = rc.model;
    double z_lo = std::numeric_limits<double>::infinity(), z_hi = 0;
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3d p(box[c & 1 ? 3 : 0], box[c & 2 ? 4 : 1], box[c & 4 ? 5 : 2]);
      const double z = cam.WorldToCamera(p).z();
      z_lo = std::min(z_lo, z);
      z_hi = std::max(z_hi, z);
    }
    stereo::StereoOptions o = options.stereo;
    o.z_min_mm = std::max(1.0, z_lo - 2.0);
    o.z_max_mm = z_hi + 2.0;
    const stereo::StereoInput input =
        stereo::LoadStereoInput(take, instant, cam.id, options.cluster);
    const double cpu = CpuSeconds();
    core::Stopwatch watch;
    pipeline::CoarseToFineStats st;
    const stereo::StereoResult r = full ? stereo::ComputeDepth(input, o)
                                        : pipeline::ComputeDepthCoarseToFine(input, o, c2f, &st);
    std::printf(
        "{\"camera\": \"%s\", \"z_mm\": [%.1f, %.1f], \"levels\": %d, \"density\": %.4f, "
        "\"seconds\": %.2f, \"cpu_seconds\": %.2f, \"coarse_levels\": %d, \"tiles\": %d, "
        "\"tiles_matched\": %d, \"tiles_filled\": %d, \"mean_tile_levels\": %.1f, "
        "\"coarse_seconds\": %.2f, "
        "\"fine_seconds\": %.2f}\n",
        cam.id.c_str(), o.z_min_mm, o.z_max_mm, r.num_levels, r.range_images[0].density,
        watch.ElapsedSeconds(), CpuSeconds() - cpu, st.coarse_levels, st.tiles, st.tiles_matched,
        st.tiles_filled, st.mean_tile_levels, st.coarse_seconds, st.fine_seconds);
    std::fflush(stdout);
    stereo::WriteStereoResult(r, instant, out, false);
  }
  std::printf("{\"total_seconds\": %.2f, \"total_cpu_seconds\": %.2f}\n", total.ElapsedSeconds(),
              CpuSeconds() - cpu0);
  return 0;
}
