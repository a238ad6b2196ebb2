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

Take ImportPanoptic(const fs::path& dir, const fs::path& out, const ImportOptions& options) {
  options.Check();
  std::error_code ec;
  const fs::path params = dir / "camera_parameters.json";
  Require(fs::is_regular_file(params, ec), params.string(), "missing");
  core::Json doc;
  try {
    doc = core::Json::parse(io::ReadFileBytes(params));
  } catch (const core::Json::exception& e) {
    throw core::InputError(params.string(), std::string("not JSON: ") + e.what());
  }
  Require(doc.contains("cameras") && doc["cameras"].is_array(), params.string() + ": cameras",
          "missing (expected an array of cameras)");
  const fs::path hd = dir / "hd";
  Require(fs::is_directory(hd, ec), hd.string(), "missing: the HD frames' folder");
  geometry::Rig rig;
  rig.source = "panoptic";
  rig.source_unit = "cm";
  rig.source_unit_mm = 10.0;
  std::vector<std::vector<std::pair<std::string, fs::path>>> frames;  // per camera
  for (size_t i = 0; i < doc["cameras"].size(); ++i) {
    const core::Json& c = doc["cameras"][i];
    const std::string name = c.value("name", "");
    const std::string where =
        params.string() + ": cameras[" + std::to_string(i) + "] '" + name + "'";
    Require(!name.empty(), where + ".name", "missing");
    if (!fs::is_directory(hd / name, ec)) continue;  // calibrated, not filmed here
    const std::vector<double> res = Numbers(c, "resolution", 2, where);
    const std::vector<double> k = Numbers(c, "K", 9, where);
    const std::vector<double> d = Numbers(c, "distCoef", 5, where);
    const std::vector<double> r = Numbers(c, "R", 9, where);
    const std::vector<double> t = Numbers(c, "t", 3, where);
    Require(
        std::abs(k[1]) <= 1e-9 * std::abs(k[0]) && k[3] == 0 && k[6] == 0 && k[7] == 0 && k[8] == 1,
        where + ".K", "must be [fx 0 cx; 0 fy cy; 0 0 1] (no skew)");
    Require(k[0] > 0 && k[4] > 0, where + ".K", "needs positive focal lengths");
    geometry::RigCamera rc;
    geometry::TsaiCamera& m = rc.model;
    m.id = name;
    m.width_px = int(res[0]);
    m.height_px = int(res[1]);
    Require(m.width_px == res[0] && m.height_px == res[1] && m.width_px > 0 && m.height_px > 0,
            where + ".resolution", "expected two positive whole numbers");
    // One sensor element per pixel of 0.01 mm (only focal / pitch matters), as pinhole.h.
    m.sensor.ncx = m.sensor.nfx = m.width_px;
    m.sensor.dx_mm = m.sensor.dy_mm = 0.01;
    m.focal_mm = k[4] * 0.01;
    m.sx = k[0] / k[4];
    m.cx_px = k[2];  // OpenCV's pixel centres are at integers, as dome's
    m.cy_px = k[5];
    m.lens = {d[0], d[1], d[2], d[3], d[4]};
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) m.rotation(a, b) = r[3 * a + b];
      m.translation_mm(a) = 10.0 * t[a];  // centimetres
    }
    m.Check(where);
    std::vector<std::pair<std::string, fs::path>> mine;
    const std::regex frame_name(name + R"(_(\d+)\.(jpg|png))");
    for (const auto& e : fs::directory_iterator(hd / name)) {
      std::smatch match;
      const std::string f = e.path().filename().string();
      if (!std::regex_match(f, match, frame_name)) continue;
      const long n = std::stol(match[1]);
      Timecode tc;
      tc.frames = int(n % 30);
      tc.seconds = int(n / 30 % 60);
      tc.minutes = int(n / 1800 % 60);
      tc.hours = int(n / 108000);
      Require(tc.hours < 24, e.path().string(), "frame number beyond 24 hours");
      mine.emplace_back(tc.FolderName(), e.path());
    }
    Require(!mine.empty(), (hd / name).string(),
            "no frames named " + name + "_<frame>.jpg for camera '" + name + "'");
    std::sort(mine.begin(), mine.end());
    frames.push_back(std::move(mine));
    rig.cameras.push_back(rc);
  }
  Require(rig.cameras.size() >= 2, hd.string(),
          "needs frames of at least two calibrated cameras, found " +
              std::to_string(rig.cameras.size()));
  for (size_t c = 1; c < frames.size(); ++c) {
    std::vector<std::string> a, b;
    for (const auto& f : frames[0]) a.push_back(f.first);
    for (const auto& f : frames[c]) b.push_back(f.first);
    Require(a == b, (hd / rig.cameras[c].model.id).string(),
            "does not hold the same frames as " + (hd / rig.cameras[0].model.id).string());
  }
  CreateTakeDir(out, options.overwrite);
  for (size_t t = 0; t < frames[0].size(); ++t) {
    const fs::path folder = out / "frames" / frames[0][t].first;
    fs::create_directories(folder, ec);
    Require(!ec, folder.string(), "cannot create folder: " + ec.message());
    for (size_t c = 0; c < frames.size(); ++c) {
      const cv::Mat image = io::ReadImage(frames[c][t].second, io::ImageMode::kUnchanged);
      const auto& m = rig.cameras[c].model;
      Require(image.cols == m.width_px && image.rows == m.height_px, frames[c][t].second.string(),
              "is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                  ", but camera '" + m.id + "' is calibrated for " + std::to_string(m.width_px) +
                  "x" + std::to_string(m.height_px));
      io::WriteImage(folder / (m.id + ".png"), image);
    }
  }
  schema::WriteRig(rig, out / "rig.json");
  return OpenTake(out);
}

}  // namespace dome::take
