// ImportOpenCv (take/import.h): per-camera cv::FileStorage calibration files.
#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/persistence.hpp>

#include "core/error.h"
#include "geometry/opencv_camera.h"
#include "take/import.h"
#include "take/import_frames.h"

namespace dome::take {
namespace {

namespace fs = std::filesystem;
using core::Require;

bool IsCalibrationFile(const fs::path& p) {
  const std::string ext = p.extension().string();
  return ext == ".yml" || ext == ".yaml" || ext == ".xml" || ext == ".json";
}

// The first of `names` present in the file's top level; throws naming the file and
// every accepted spelling when none is.
cv::FileNode Field(const cv::FileStorage& storage, const fs::path& file,
                   std::initializer_list<const char*> names, const std::string& what) {
  std::string spellings;
  for (const char* name : names) {
    const cv::FileNode node = storage[name];
    if (!node.empty()) return node;
    spellings += std::string(spellings.empty() ? "" : ", ") + name;
  }
  throw core::InputError(file.string() + ": " + what,
                         "missing (expected one of " + spellings + ")");
}

// The numbers of a matrix (!!opencv-matrix, as cv::FileStorage writes cv::Mat) or a
// sequence of numbers (nested sequences flattened), row by row.
std::vector<double> Numbers(const cv::FileNode& node, const std::string& where) {
  std::vector<double> out;
  try {
    if (node.isMap()) {
      cv::Mat m;
      node >> m;
      Require(!m.empty() && m.channels() == 1, where, "expected a matrix of numbers");
      m.convertTo(m, CV_64F);
      for (int r = 0; r < m.rows; ++r)
        for (int c = 0; c < m.cols; ++c) out.push_back(m.at<double>(r, c));
    } else if (node.isSeq()) {
      for (const auto& e : node) {
        const std::vector<double> inner = Numbers(e, where);
        out.insert(out.end(), inner.begin(), inner.end());
      }
    } else {
      Require(node.isReal() || node.isInt(), where, "expected numbers");
      out.push_back(node.real());
    }
  } catch (const cv::Exception& e) {
    throw core::InputError(where, std::string("cannot be read as numbers: ") + e.what());
  }
  for (double v : out) Require(std::isfinite(v), where, "holds a number that is not finite");
  return out;
}

std::vector<double> Numbers(const cv::FileStorage& storage, const fs::path& file,
                            std::initializer_list<const char*> names, const std::string& what,
                            std::initializer_list<size_t> counts) {
  const std::vector<double> v =
      Numbers(Field(storage, file, names, what), file.string() + ": " + what);
  std::string expected;
  for (size_t n : counts) {
    if (v.size() == n) return v;
    expected += std::string(expected.empty() ? "" : " or ") + std::to_string(n);
  }
  throw core::InputError(file.string() + ": " + what,
                         "expected " + expected + " numbers, got " + std::to_string(v.size()));
}

geometry::TsaiCamera ReadCamera(const fs::path& file, double mm_per_unit) {
  cv::FileStorage storage;
  try {
    storage.open(file.string(), cv::FileStorage::READ);
  } catch (const cv::Exception& e) {
    throw core::InputError(file.string(), std::string("not a cv::FileStorage file: ") + e.what());
  }
  Require(storage.isOpened(), file.string(), "cannot be opened as a cv::FileStorage file");
  geometry::OpenCvCamera c;
  c.id = file.stem().string();
  if (!storage["image_width"].empty() || !storage["image_height"].empty()) {
    c.width_px = int(Numbers(storage, file, {"image_width"}, "image_width", {1})[0]);
    c.height_px = int(Numbers(storage, file, {"image_height"}, "image_height", {1})[0]);
  } else {
    const std::vector<double> size =
        Numbers(storage, file, {"image_size", "imageSize"}, "image size", {2});
    c.width_px = int(size[0]);
    c.height_px = int(size[1]);
  }
  const std::vector<double> k =
      Numbers(storage, file, {"camera_matrix", "cameraMatrix", "K"}, "camera matrix", {9});
  c.distortion =
      Numbers(storage, file, {"distortion_coefficients", "distCoeffs", "dist_coeffs", "D"},
              "distortion", {4, 5, 8, 12, 14});
  std::vector<double> r;
  if (!storage["rvec"].empty() && storage["R"].empty()) {
    const std::vector<double> rvec = Numbers(storage, file, {"rvec"}, "rvec", {3});
    cv::Mat m;
    cv::Rodrigues(cv::Mat(rvec, true), m);
    r.assign(m.begin<double>(), m.end<double>());
  } else {
    r = Numbers(storage, file, {"R"}, "rotation (R or rvec)", {9});
  }
  const std::vector<double> t = Numbers(storage, file, {"T", "t", "tvec"}, "translation", {3});
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      c.k(a, b) = k[3 * a + b];
      c.r(a, b) = r[3 * a + b];
    }
    c.t_mm(a) = mm_per_unit * t[a];
  }
  return geometry::CameraFromOpenCv(c, file.string());
}

}  // namespace

Take ImportOpenCv(const fs::path& calib_dir, const fs::path& images_dir, const fs::path& out,
                  double mm_per_unit, const ImportOptions& options) {
  options.Check();
  Require(std::isfinite(mm_per_unit) && mm_per_unit > 0, "--mm-per-unit",
          "must be a positive number of millimetres per unit of T");
  std::error_code ec;
  Require(fs::is_directory(calib_dir, ec), calib_dir.string(),
          "not a folder of per-camera calibration files");
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(calib_dir)) {
    if (e.is_regular_file() && IsCalibrationFile(e.path())) files.push_back(e.path());
  }
  Require(!files.empty(), calib_dir.string(),
          "holds no calibration files (<camera>.yml, .yaml, .xml or .json)");
  std::sort(files.begin(), files.end());
  geometry::Rig rig;
  rig.source = "opencv";
  rig.source_unit = "unit of T";
  rig.source_unit_mm = mm_per_unit;
  for (const fs::path& file : files) {
    for (const auto& other : rig.cameras) {
      Require(other.model.id != file.stem().string(), file.string(),
              "a second calibration file for camera '" + other.model.id + "'");
    }
    geometry::RigCamera rc;
    rc.model = ReadCamera(file, mm_per_unit);
    rig.cameras.push_back(rc);
  }
  std::vector<internal::CameraFrames> frames;
  if (!images_dir.empty()) {
    Require(fs::is_directory(images_dir, ec), images_dir.string(), "not a folder of images");
    std::vector<fs::path> folders;
    for (const auto& rc : rig.cameras) {
      const std::string& id = rc.model.id;
      if (fs::is_directory(images_dir / id, ec)) {
        frames.push_back(internal::NumberedFrames(images_dir / id, ""));
        folders.push_back(images_dir / id);
        continue;
      }
      fs::path image;
      for (const char* ext : {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".PNG", ".JPG"}) {
        if (fs::is_regular_file(images_dir / (id + ext), ec)) image = images_dir / (id + ext);
      }
      Require(!image.empty(), (images_dir / id).string(),
              "missing: camera '" + id + "' has no image (<camera>.png|jpg) or frame folder");
      frames.push_back({{options.instant, image}});
      folders.push_back(image);
    }
    internal::RequireSameInstants(frames, folders);
  }
  return internal::WriteFrames(rig, frames, out, options.overwrite);
}

}  // namespace dome::take
