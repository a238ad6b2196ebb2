#include "take/import.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <fstream>
#include <regex>

#include "core/error.h"
#include "geometry/colmap.h"
#include "geometry/halcon.h"
#include "geometry/middlebury.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "schema/rig_json.h"
#include "take/timecode.h"

namespace dome::take {
namespace {

namespace fs = std::filesystem;
using core::Require;

// Copies an image into the take as PNG: byte copy for PNG sources, re-encoding
// (lossless, 8-bit, channels kept) for anything else.
void CopyImage(const fs::path& from, const fs::path& to) {
  if (from.extension() == ".png" || from.extension() == ".PNG") {
    // Decode once so a corrupt source fails here, naming the source file.
    io::ReadImage(from, io::ImageMode::kUnchanged);
    io::WriteFileAtomically(to, io::ReadFileBytes(from));
  } else {
    io::WriteImage(to, io::ReadImage(from, io::ImageMode::kUnchanged));
  }
}

// Writes rig.json and frames/<instant>/<id>.png for each (camera, image) pair.
Take WriteImportedTake(geometry::Rig rig, const std::vector<fs::path>& images, const fs::path& out,
                       const ImportOptions& options) {
  DOME_CHECK(rig.cameras.size() == images.size(), "one image per camera");
  CreateTakeDir(out, options.overwrite);
  const fs::path frames = out / "frames" / options.instant;
  std::error_code ec;
  fs::remove_all(frames, ec);
  fs::create_directories(frames, ec);
  Require(!ec, frames.string(), "cannot create folder: " + ec.message());
  for (size_t i = 0; i < images.size(); ++i) {
    CopyImage(images[i], frames / (rig.cameras[i].model.id + ".png"));
  }
  schema::WriteRig(rig, out / "rig.json");
  return OpenTake(out);
}

}  // namespace

void ImportOptions::Check() const {
  Require(ParseInstantName(instant).has_value(), "--instant",
          "expected a timecode HH-MM-SS-FF, got '" + instant + "'");
}

Take ImportHalconScene(const fs::path& scene_dir, const fs::path& out,
                       const ImportOptions& options) {
  options.Check();
  std::error_code ec;
  Require(fs::is_directory(scene_dir, ec), scene_dir.string(), "not a folder");
  const std::regex intrinsics_name(R"(intrinsics_(camera\w+)\.txt)");
  std::vector<std::string> ids;
  for (const auto& entry : fs::directory_iterator(scene_dir)) {
    std::smatch m;
    const std::string name = entry.path().filename().string();
    if (std::regex_match(name, m, intrinsics_name)) ids.push_back(m[1]);
  }
  Require(!ids.empty(), scene_dir.string(),
          "no HALCON cameras: expected intrinsics_<camera>.txt files");
  std::sort(ids.begin(), ids.end());
  geometry::Rig rig;
  rig.source = "halcon";
  rig.source_unit = "m";
  rig.source_unit_mm = 1000.0;
  std::vector<fs::path> images;
  for (const auto& id : ids) {
    const fs::path extrinsics = scene_dir / ("extrinsics_" + id + ".txt");
    const fs::path image = scene_dir / ("image_" + id + ".png");
    Require(fs::is_regular_file(extrinsics, ec), extrinsics.string(),
            "missing: every intrinsics file needs its extrinsics file");
    Require(fs::is_regular_file(image, ec), image.string(),
            "missing: every camera needs its image");
    geometry::RigCamera cam;
    cam.model = geometry::ReadHalconCamera((scene_dir / ("intrinsics_" + id + ".txt")).string(),
                                           extrinsics.string(), id);
    rig.cameras.push_back(cam);
    images.push_back(image);
  }
  Take take = WriteImportedTake(rig, images, out, options);
  const fs::path reference = scene_dir / "reference.ply";
  if (fs::is_regular_file(reference, ec)) {
    fs::create_directories(out / "reference", ec);
    io::WriteFileAtomically(out / "reference" / "reference.ply", io::ReadFileBytes(reference));
  }
  return take;
}

Take ImportMiddlebury(const fs::path& par_file, const fs::path& out, const ImportOptions& options) {
  options.Check();
  std::error_code ec;
  Require(fs::is_regular_file(par_file, ec), par_file.string(),
          "missing Middlebury *_par.txt file");
  // The par file does not store image sizes. The images of a Middlebury set share one
  // camera, so the size comes from the first image named (line 2, first token) and
  // every other image is checked against it.
  std::string first_name;
  {
    std::ifstream in(par_file);
    int count = 0;
    in >> count >> first_name;
    Require(static_cast<bool>(in) && count > 0, par_file.string(),
            "expected an image count and at least one image line");
  }
  const fs::path dir = par_file.parent_path();
  const cv::Mat first = io::ReadImage(dir / first_name, io::ImageMode::kUnchanged);
  geometry::MiddleburyReadOptions read_options;
  read_options.width_px = first.cols;
  read_options.height_px = first.rows;
  const std::vector<geometry::TsaiCamera> cameras =
      geometry::ReadMiddleburyPar(par_file.string(), read_options);
  geometry::Rig rig;
  rig.source = "middlebury";
  rig.source_unit = "m";
  rig.source_unit_mm = read_options.mm_per_unit;
  std::vector<fs::path> images;
  for (const auto& model : cameras) {
    const fs::path image_path = dir / model.id;
    const cv::Mat image = io::ReadImage(image_path, io::ImageMode::kUnchanged);
    Require(image.cols == first.cols && image.rows == first.rows, image_path.string(),
            "image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                ", expected the set's " + std::to_string(first.cols) + "x" +
                std::to_string(first.rows));
    geometry::RigCamera cam;
    cam.model = model;
    cam.model.id = fs::path(model.id).stem().string();
    rig.cameras.push_back(cam);
    images.push_back(image_path);
  }
  return WriteImportedTake(rig, images, out, options);
}

Take ImportColmap(const fs::path& sparse_dir, const fs::path& images_dir, const fs::path& out,
                  double mm_per_unit, const ImportOptions& options) {
  options.Check();
  geometry::ColmapReadOptions read_options;
  read_options.mm_per_unit = mm_per_unit;
  read_options.Check();
  std::error_code ec;
  Require(fs::is_directory(images_dir, ec), images_dir.string(), "not a folder of images");
  const std::vector<geometry::ColmapImage> model =
      geometry::ReadColmapModel(sparse_dir.string(), read_options);
  Require(!model.empty(), (sparse_dir / "images.txt").string(), "no images in the model");
  geometry::Rig rig;
  rig.source = "colmap";
  rig.source_unit = "model unit";
  rig.source_unit_mm = mm_per_unit;
  std::vector<fs::path> images;
  for (const auto& image : model) {
    geometry::RigCamera cam;
    cam.model = image.camera;
    cam.model.id = fs::path(image.name).stem().string();
    if (!image.distortion_fit.exact) {
      spdlog::info("{}: COLMAP radial distortion converted to Tsai kappa1, max residual {:.4f} px",
                   image.name, image.distortion_fit.max_residual_px);
    }
    rig.cameras.push_back(cam);
    images.push_back(images_dir / image.name);
  }
  return WriteImportedTake(rig, images, out, options);
}

}  // namespace dome::take
