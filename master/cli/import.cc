// `dome import halcon|middlebury|colmap ... --out TAKE`: make a take from another
// tool's calibrated images (take/import.h).
#include "take/import.h"

#include <cstdio>
#include <memory>
#include <string>

#include "cli/commands.h"

namespace dome::cli {
namespace {

struct ImportArgs {
  std::string source;
  std::string images;
  std::string out;
  double mm_per_unit = 0.0;
  take::ImportOptions options;
};

void AddCommonOptions(CLI::App* cmd, ImportArgs* args) {
  cmd->add_option("--out", args->out, "take folder to write")->required();
  cmd->add_option("--instant", args->options.instant, "instant name (timecode HH-MM-SS-FF)");
  cmd->add_flag("--overwrite", args->options.overwrite, "replace an existing take");
}

void PrintImported(const take::Take& take) {
  std::printf("wrote take %s: %zu camera(s), instant %s\n", take.dir.c_str(),
              take.rig.cameras.size(), take.instants.front().c_str());
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
  halcon->callback(
      [=] { PrintImported(take::ImportHalconScene(args->source, args->out, args->options)); });

  auto* middlebury = cmd->add_subcommand("middlebury", "A Middlebury multi-view set (*_par.txt)");
  middlebury->add_option("PAR_FILE", args->source, "the *_par.txt file; images beside it")
      ->required();
  AddCommonOptions(middlebury, args.get());
  middlebury->callback(
      [=] { PrintImported(take::ImportMiddlebury(args->source, args->out, args->options)); });

  auto* colmap = cmd->add_subcommand("colmap", "A COLMAP text model (cameras.txt, images.txt)");
  colmap->add_option("SPARSE_DIR", args->source, "folder with cameras.txt and images.txt")
      ->required();
  colmap->add_option("IMAGES_DIR", args->images, "folder with the images")->required();
  colmap->add_option("--mm-per-unit", args->mm_per_unit, "millimetres per model unit")->required();
  AddCommonOptions(colmap, args.get());
  colmap->callback([=] {
    PrintImported(take::ImportColmap(args->source, args->images, args->out, args->mm_per_unit,
                                     args->options));
  });
  *exit_code = 0;
}

}  // namespace dome::cli
