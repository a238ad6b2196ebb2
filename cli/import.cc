// `dome import halcon|middlebury|colmap|panoptic|opencv|video ... --out TAKE`: make a
// take from another tool's calibrated images or videos (take/import.h), optionally
// cropped to a world box (take/crop.h): --crop-box X0 Y0 Z0 X1 Y1 Z1 (mm)
// [--crop-margin-px N].
#include "take/import.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "core/error.h"
#include "schema/rig_json.h"
#include "take/crop.h"

namespace dome::cli {
namespace {

struct ImportArgs {
  std::string source;
  std::string images;
  std::string out;
  double mm_per_unit = 0.0;
  take::ImportOptions options;
  std::vector<double> crop_box;  // x0 y0 z0 x1 y1 z1, world mm; empty: no crop
  int crop_margin_px = take::CropBox{}.margin_px;
  take::PanopticOptions panoptic;
  take::VideoImportOptions video;
  std::vector<std::string> offsets, starts;  // video: ID=N, ID=TIMECODE
};

// "ID=VALUE" flags (video --offset, --start) as a map; errors name the flag.
std::map<std::string, std::string> Assignments(const std::vector<std::string>& flags,
                                               const std::string& flag) {
  std::map<std::string, std::string> out;
  for (const std::string& f : flags) {
    const size_t eq = f.find('=');
    core::Require(eq != std::string::npos && eq > 0 && eq + 1 < f.size(), flag,
                  "expected CAMERA=VALUE, got '" + f + "'");
    core::Require(out.emplace(f.substr(0, eq), f.substr(eq + 1)).second, flag,
                  "camera '" + f.substr(0, eq) + "' given twice");
  }
  return out;
}

// The rig of a video import: a rig.json, or the rig of a take folder.
geometry::Rig RigOf(const std::string& source) {
  const std::filesystem::path path(source);
  std::error_code ec;
  return schema::ReadRig(std::filesystem::is_directory(path, ec) ? path / "rig.json" : path);
}

// The --crop-box flags as a checked box.
take::CropBox CropBoxOf(const ImportArgs& args) {
  take::CropBox box;
  box.min_mm = Eigen::Vector3d(args.crop_box[0], args.crop_box[1], args.crop_box[2]);
  box.max_mm = Eigen::Vector3d(args.crop_box[3], args.crop_box[4], args.crop_box[5]);
  box.margin_px = args.crop_margin_px;
  box.Check("--crop-box");
  return box;
}

void AddCommonOptions(CLI::App* cmd, ImportArgs* args) {
  cmd->add_option("--out", args->out, "take folder to write")->required();
  cmd->add_option("--instant", args->options.instant, "instant name (timecode HH-MM-SS-FF)");
  cmd->add_flag("--overwrite", args->options.overwrite, "replace an existing take");
  cmd->add_option("--crop-box", args->crop_box,
                  "cut each frame to where this world box (x0 y0 z0 x1 y1 z1, mm) projects")
      ->expected(6);
  cmd->add_option("--crop-margin-px", args->crop_margin_px,
                  "pixels kept around the box's projection (--crop-box)")
      ->capture_default_str();
  // A bad box fails before anything is written.
  cmd->parse_complete_callback([args] {
    if (!args->crop_box.empty()) CropBoxOf(*args);
  });
}

// Crops the written take when asked, then reports it.
void FinishImport(const ImportArgs& args, const take::Take& take) {
  if (take.instants.empty()) {
    std::printf("wrote take %s: %zu camera(s), rig only (no images)\n", take.dir.c_str(),
                take.rig.cameras.size());
    core::Require(args.crop_box.empty(), "--crop-box", "a rig-only take has no images to crop");
    return;
  }
  std::printf("wrote take %s: %zu camera(s), %zu instant(s) from %s\n", take.dir.c_str(),
              take.rig.cameras.size(), take.instants.size(), take.instants.front().c_str());
  if (args.crop_box.empty()) return;
  const take::CropSummary c = take::CropTakeToBox(take.dir, CropBoxOf(args));
  std::printf("cropped %d camera(s) to the box: %.1f%% of the pixels kept\n", c.cameras_cropped,
              100.0 * c.pixel_fraction);
}

}  // namespace

void AddImportCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand("import", "Make a take from another tool's calibrated images");
  cmd->require_subcommand(1);
  auto args = std::make_shared<ImportArgs>();

  auto* halcon =
      cmd->add_subcommand("halcon", "A Robovision scene folder (HALCON 12 camera files)");
  halcon->add_option("SCENE_DIR", args->source, "scene folder")->required();
  AddCommonOptions(halcon, args.get());
  halcon->callback([=] {
    FinishImport(*args, take::ImportHalconScene(args->source, args->out, args->options));
  });

  auto* middlebury = cmd->add_subcommand("middlebury", "A Middlebury multi-view set (*_par.txt)");
  middlebury->add_option("PAR_FILE", args->source, "the *_par.txt file; images beside it")
      ->required();
  AddCommonOptions(middlebury, args.get());
  middlebury->callback(
      [=] { FinishImport(*args, take::ImportMiddlebury(args->source, args->out, args->options)); });

  auto* colmap = cmd->add_subcommand("colmap", "A COLMAP text model (cameras.txt, images.txt)");
  colmap->add_option("SPARSE_DIR", args->source, "folder with cameras.txt and images.txt")
      ->required();
  colmap->add_option("IMAGES_DIR", args->images, "folder with the images")->required();
  colmap->add_option("--mm-per-unit", args->mm_per_unit, "millimetres per model unit")->required();
  AddCommonOptions(colmap, args.get());
  colmap->callback([=] {
    FinishImport(*args, take::ImportColmap(args->source, args->images, args->out, args->mm_per_unit,
                                           args->options));
  });
  auto* panoptic = cmd->add_subcommand(
      "panoptic",
      "CMU Panoptic Studio: a calibration JSON and <camera>/<camera>_<frame>.jpg frames");
  panoptic
      ->add_option("SOURCE", args->source,
                   "calibration JSON, or a folder with camera_parameters.json and hd/")
      ->required();
  panoptic->add_option("IMAGES_DIR", args->images,
                       "folder of <camera>/ frame folders (default SOURCE/hd for a folder; "
                       "none for a JSON file: a rig-only take)");
  panoptic->add_option("--cameras", args->panoptic.cameras, "import only these cameras, by name")
      ->delimiter(',');
  AddCommonOptions(panoptic, args.get());
  panoptic->callback([=] {
    std::filesystem::path calibration(args->source), images(args->images);
    std::error_code ec;
    if (std::filesystem::is_directory(calibration, ec)) {
      if (images.empty()) images = calibration / "hd";
      calibration /= "camera_parameters.json";
    }
    FinishImport(
        *args, take::ImportPanoptic(calibration, images, args->out, args->panoptic, args->options));
  });

  auto* opencv = cmd->add_subcommand(
      "opencv", "Per-camera OpenCV FileStorage files (<camera>.yml|xml|json: size, K, D, R, T)");
  opencv->add_option("CALIB_DIR", args->source, "folder of <camera>.yml|yaml|xml|json")->required();
  opencv->add_option("IMAGES_DIR", args->images,
                     "folder of <camera>.png|jpg or <camera>/ numbered frames (none: rig only)");
  opencv->add_option("--mm-per-unit", args->mm_per_unit, "millimetres per unit of T")->required();
  AddCommonOptions(opencv, args.get());
  opencv->callback([=] {
    FinishImport(*args, take::ImportOpenCv(args->source, args->images, args->out, args->mm_per_unit,
                                           args->options));
  });

  auto* video = cmd->add_subcommand(
      "video", "One video per camera (<camera>.<ext>, any codec FFmpeg decodes) with a rig");
  video->add_option("RIG", args->source, "rig.json, or a take folder whose rig to use")->required();
  video->add_option("VIDEO_DIR", args->images, "folder of <camera>.<ext> videos")->required();
  video->add_option("--offset", args->offsets,
                    "CAMERA=N: the camera's first frame is timeline frame N (repeatable)");
  video->add_option("--start", args->starts,
                    "CAMERA=HH:MM:SS:FF: the timecode of the camera's first frame (repeatable)");
  video
      ->add_option("--range", args->video.range,
                   "FIRST LAST timeline frames (numbers or timecodes), inclusive")
      ->expected(2);
  video->add_option("--every", args->video.every, "every Nth frame of the range")
      ->capture_default_str();
  video
      ->add_option("--instants", args->video.instants,
                   "exactly these timeline frames (numbers or timecodes, comma-separated)")
      ->delimiter(',');
  video->add_option("--fps", args->video.fps,
                    "timeline frames a second, 1..30 (default: the videos' own rate)");
  AddCommonOptions(video, args.get());
  video->callback([=] {
    for (const auto& [id, n] : Assignments(args->offsets, "--offset")) {
      char* end = nullptr;
      const long frames = std::strtol(n.c_str(), &end, 10);
      core::Require(*end == 0, "--offset " + id,
                    "expected a whole number of frames, got '" + n + "'");
      args->video.offset_frames[id] = frames;
    }
    for (const auto& [id, tc] : Assignments(args->starts, "--start")) {
      args->video.start_timecodes[id] = tc;
    }
    FinishImport(*args, take::ImportVideo(RigOf(args->source), args->images, args->out, args->video,
                                          args->options));
  });
  *exit_code = 0;
}

}  // namespace dome::cli
