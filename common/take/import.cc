#include "take/import.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <regex>

#include "core/error.h"
#include "core/json.h"
#include "geometry/colmap.h"
#include "geometry/halcon.h"
#include "geometry/middlebury.h"
#include "geometry/opencv_camera.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "schema/rig_json.h"
#include "take/import_frames.h"
#include "take/timecode.h"

namespace dome::take {
namespace {

namespace fs = std::filesystem;
using core::Require;

// Writes rig.json and frames/<instant>/<id>.png for each (camera, image) pair, and
// `reference` (when given) to reference/ unchanged.
Take WriteImportedTake(const geometry::Rig& rig, const std::vector<fs::path>& images,
                       const fs::path& out, const ImportOptions& options,
                       const fs::path& reference = {}) {
  DOME_CHECK(rig.cameras.size() == images.size(), "one image per camera");
  TakeWriter writer(out, options.overwrite);
  for (size_t i = 0; i < images.size(); ++i) {
    const geometry::TsaiCamera& camera = rig.cameras[i].model;
    internal::CopyImage(images[i], writer.FramePath(options.instant, camera.id), camera);
  }
  if (!reference.empty()) {
    io::WriteFileAtomically(writer.Staged(fs::path("reference") / reference.filename()),
                            io::ReadFileBytes(reference));
  }
  return writer.Commit(rig);
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
  const fs::path reference = scene_dir / "reference.ply";
  return WriteImportedTake(rig, images, out, options,
                           fs::is_regular_file(reference, ec) ? reference : fs::path());
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

namespace {

// The numbers of a JSON array of `n` numbers at `field` of `camera` (errors name both).
std::vector<double> Numbers(const core::Json& camera, const char* field, size_t n,
                            const std::string& where) {
  const auto it = camera.find(field);
  Require(it != camera.end(), where + "." + field, "missing");
  std::vector<double> out;
  const auto flat = [&](const core::Json& v, auto&& self) -> void {
    if (v.is_array()) {
      for (const auto& e : v) self(e, self);
    } else {
      Require(v.is_number() && std::isfinite(v.get<double>()), where + "." + field,
              "expected numbers, got " + v.dump());
      out.push_back(v.get<double>());
    }
  };
  flat(*it, flat);
  Require(out.size() == n, where + "." + field,
          "expected " + std::to_string(n) + " numbers, got " + std::to_string(out.size()));
  return out;
}

}  // namespace

Take ImportPanoptic(const fs::path& calibration, const fs::path& images_dir, const fs::path& out,
                    const PanopticOptions& panoptic, const ImportOptions& options) {
  options.Check();
  std::error_code ec;
  Require(fs::is_regular_file(calibration, ec), calibration.string(), "missing");
  core::Json doc;
  try {
    doc = core::Json::parse(io::ReadFileBytes(calibration));
  } catch (const core::Json::exception& e) {
    // NaN and Infinity, which some JSON writers emit, are not JSON either.
    throw core::InputError(calibration.string(), std::string("not JSON: ") + e.what());
  }
  Require(doc.contains("cameras") && doc["cameras"].is_array(), calibration.string() + ": cameras",
          "missing (expected an array of cameras)");
  const bool with_images = !images_dir.empty();
  Require(!with_images || fs::is_directory(images_dir, ec), images_dir.string(),
          "missing: the folder of <camera>/<camera>_<frame>.jpg frames");
  for (const std::string& name : panoptic.cameras) {
    bool listed = false;
    for (const auto& c : doc["cameras"]) listed = listed || c.value("name", "") == name;
    Require(listed, "--cameras", "camera '" + name + "' is not in " + calibration.string());
  }
  geometry::Rig rig;
  rig.source = "panoptic";
  rig.source_unit = "cm";
  rig.source_unit_mm = 10.0;
  std::vector<internal::CameraFrames> frames;  // per camera, when with images
  std::vector<fs::path> folders;
  for (size_t i = 0; i < doc["cameras"].size(); ++i) {
    const core::Json& c = doc["cameras"][i];
    const std::string name = c.is_object() ? c.value("name", "") : "";
    const std::string where =
        calibration.string() + ": cameras[" + std::to_string(i) + "] '" + name + "'";
    Require(!name.empty(), where + ".name", "missing");
    const bool named =
        std::find(panoptic.cameras.begin(), panoptic.cameras.end(), name) != panoptic.cameras.end();
    if (!panoptic.cameras.empty() && !named) continue;
    if (with_images && !fs::is_directory(images_dir / name, ec)) {
      // Calibrated but not filmed here: skipped unless asked for by name.
      Require(!named, (images_dir / name).string(),
              "missing: camera '" + name + "' (--cameras) has no frames");
      continue;
    }
    const std::vector<double> res = Numbers(c, "resolution", 2, where);
    const std::vector<double> k = Numbers(c, "K", 9, where);
    const std::vector<double> r = Numbers(c, "R", 9, where);
    const std::vector<double> t = Numbers(c, "t", 3, where);
    geometry::OpenCvCamera source;
    source.id = name;
    source.width_px = int(res[0]);
    source.height_px = int(res[1]);
    Require(source.width_px == res[0] && source.height_px == res[1], where + ".resolution",
            "expected two whole numbers");
    source.distortion = Numbers(c, "distCoef", 5, where);
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) {
        source.k(a, b) = k[3 * a + b];
        source.r(a, b) = r[3 * a + b];
      }
      source.t_mm(a) = 10.0 * t[a];  // centimetres
    }
    geometry::RigCamera rc;
    rc.model = geometry::CameraFromOpenCv(source, where);
    rig.cameras.push_back(rc);
    if (!with_images) continue;
    frames.push_back(internal::NumberedFrames(images_dir / name, name + "_"));
    folders.push_back(images_dir / name);
  }
  Require(!rig.cameras.empty(), with_images ? images_dir.string() : calibration.string(),
          with_images ? "holds no frame folder of a calibrated camera" : "no cameras");
  Require(!with_images || rig.cameras.size() >= 2, images_dir.string(),
          "needs frames of at least two calibrated cameras, found " +
              std::to_string(rig.cameras.size()));
  internal::RequireSameInstants(frames, folders);
  return internal::WriteFrames(rig, frames, out, options.overwrite);
}

}  // namespace dome::take
