// `dome import halcon|middlebury|colmap|panoptic ... --out TAKE`: make a take from another
// tool's calibrated images (take/import.h), optionally cropped to a world box
// (take/crop.h): --crop-box X0 Y0 Z0 X1 Y1 Z1 (mm) [--crop-margin-px N].
#include "take/import.h"

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "core/error.h"
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
};

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
      "panoptic", "A CMU Panoptic excerpt (camera_parameters.json, hd/<camera>/ frames)");
  panoptic->add_option("DIR", args->source, "folder with camera_parameters.json and hd/")
      ->required();
  AddCommonOptions(panoptic, args.get());
  panoptic->callback(
      [=] { FinishImport(*args, take::ImportPanoptic(args->source, args->out, args->options)); });
  *exit_code = 0;
}

}  // namespace dome::cli
