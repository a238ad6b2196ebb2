#include "geometry/colmap.h"

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <set>

#include "core/error.h"
#include "geometry/parse_util.h"

namespace dome::geometry {
namespace {

using internal::FormatDouble;
using internal::ParseDouble;
using internal::ParseInt;
using internal::Where;

// COLMAP: centre of the top-left pixel at (0.5, 0.5); dome: (0, 0).
constexpr double kColmapPixelOffset = 0.5;

struct ColmapCamera {
  TsaiCamera intrinsics;  // pose left at identity
  RadialFitReport fit;
};

bool HasWhitespace(const std::string& text) {
  return text.find_first_of(" \t\r\n\v\f") != std::string::npos;
}

std::string LineWhere(const std::string& path, size_t line_index) {
  return Where(path, "line " + std::to_string(line_index + 1));
}

std::map<int, ColmapCamera> ReadCameras(const std::string& path, const ColmapReadOptions& options) {
  std::map<int, ColmapCamera> cameras;
  const std::vector<std::string> lines = internal::SplitLines(internal::ReadTextFile(path));
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string_view line = internal::Trim(lines[i]);
    if (line.empty() || line[0] == '#') {
      continue;
    }
    const std::string where = LineWhere(path, i);
    const std::vector<std::string> tokens = internal::SplitWhitespace(line);
    core::Require(tokens.size() >= 4, where,
                  "expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[], got " +
                      std::to_string(tokens.size()) + " fields");
    const int camera_id = ParseInt(tokens[0], where + ": CAMERA_ID");
    const std::string& model = tokens[1];
    const std::string camera_where = where + " (camera " + std::to_string(camera_id) + ")";
    core::Require(cameras.count(camera_id) == 0, camera_where + ": CAMERA_ID",
                  "camera id appears twice");

    struct ModelInfo {
      const char* name;
      std::vector<const char*> params;
    };
    static const ModelInfo kModels[] = {
        {"SIMPLE_PINHOLE", {"f", "cx", "cy"}},
        {"PINHOLE", {"fx", "fy", "cx", "cy"}},
        {"SIMPLE_RADIAL", {"f", "cx", "cy", "k"}},
        {"RADIAL", {"f", "cx", "cy", "k1", "k2"}},
        {"OPENCV", {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"}},
    };
    const ModelInfo* info = nullptr;
    for (const ModelInfo& m : kModels) {
      if (model == m.name) {
        info = &m;
      }
    }
    core::Require(info != nullptr, camera_where + ": MODEL",
                  "unsupported camera model '" + model +
                      "'; supported: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV "
                      "(with p1 = p2 = 0)");
    core::Require(tokens.size() == 4 + info->params.size(), camera_where,
                  "model " + model + " takes " + std::to_string(info->params.size()) +
                      " parameters, got " + std::to_string(tokens.size() - 4));
    std::map<std::string, double> p;
    const std::string param_where =
        std::string(camera_where).append(": ").append(model).append(" ");
    for (size_t k = 0; k < info->params.size(); ++k) {
      p[info->params[k]] = ParseDouble(tokens[4 + k], param_where + info->params[k]);
    }
    if (p.count("p1")) {
      for (const char* tangential : {"p1", "p2"}) {
        core::Require(p[tangential] == 0.0, camera_where + ": OPENCV " + tangential,
                      "is " + FormatDouble(p[tangential]) +
                          "; tangential distortion has no Tsai equivalent (must be 0)");
      }
    }
    PinholeCamera pinhole;
    pinhole.id = "colmap camera " + std::to_string(camera_id);
    pinhole.width_px = ParseInt(tokens[2], camera_where + ": WIDTH");
    pinhole.height_px = ParseInt(tokens[3], camera_where + ": HEIGHT");
    const double fx = p.count("f") ? p["f"] : p["fx"];
    const double fy = p.count("f") ? p["f"] : p["fy"];
    pinhole.K << fx, 0.0, p["cx"] - kColmapPixelOffset,  //
        0.0, fy, p["cy"] - kColmapPixelOffset,           //
        0.0, 0.0, 1.0;
    pinhole.k1 = p.count("k") ? p["k"] : (p.count("k1") ? p["k1"] : 0.0);
    pinhole.k2 = p.count("k2") ? p["k2"] : 0.0;
    pinhole.Check(camera_where);
    ColmapCamera camera;
    camera.intrinsics = TsaiFromPinhole(pinhole, options.pinhole, &camera.fit);
    cameras.emplace(camera_id, std::move(camera));
  }
  return cameras;
}

// Validates a POINTS2D line: (X Y POINT3D_ID) triples. Returns the number of triples.
int CheckPointsLine(const std::string& line, const std::string& where) {
  const std::vector<std::string> tokens = internal::SplitWhitespace(line);
  core::Require(tokens.size() % 3 == 0, where,
                "POINTS2D must be (X Y POINT3D_ID) triples, got " + std::to_string(tokens.size()) +
                    " fields");
  for (size_t k = 0; k < tokens.size(); k += 3) {
    const std::string point = where + ": POINTS2D[" + std::to_string(k / 3) + "]";
    ParseDouble(tokens[k], point + ".X");
    ParseDouble(tokens[k + 1], point + ".Y");
    // POINT3D_ID is -1 for no point, else a 64-bit id: check it is an integer.
    const std::string id(internal::Trim(tokens[k + 2]));
    size_t used = 0;
    bool ok = !id.empty();
    try {
      (void)std::stoll(id, &used);
    } catch (const std::exception&) {
      ok = false;
    }
    core::Require(ok && used == id.size(), point + ".POINT3D_ID",
                  "expected an integer, got '" + id + "'");
  }
  return static_cast<int>(tokens.size() / 3);
}

}  // namespace

void ColmapReadOptions::Check() const {
  core::Require(std::isfinite(mm_per_unit) && mm_per_unit > 0.0, "ColmapReadOptions.mm_per_unit",
                "must be positive and finite (COLMAP models have no scale; say how many mm one "
                "model unit is), got " +
                    FormatDouble(mm_per_unit));
  pinhole.Check();
}

void ColmapWriteOptions::Check() const {
  core::Require(std::isfinite(mm_per_unit) && mm_per_unit > 0.0, "ColmapWriteOptions.mm_per_unit",
                "must be positive and finite, got " + FormatDouble(mm_per_unit));
  pinhole.Check();
}

std::vector<ColmapImage> ReadColmapModel(const std::string& folder,
                                         const ColmapReadOptions& options) {
  return ReadColmapModelFiles(folder + "/cameras.txt", folder + "/images.txt", options);
}

std::vector<ColmapImage> ReadColmapModelFiles(const std::string& cameras_path,
                                              const std::string& images_path,
                                              const ColmapReadOptions& options) {
  options.Check();
  const std::map<int, ColmapCamera> cameras = ReadCameras(cameras_path, options);
  const std::vector<std::string> lines = internal::SplitLines(internal::ReadTextFile(images_path));
  std::vector<ColmapImage> images;
  std::set<int> image_ids;
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string_view line = internal::Trim(lines[i]);
    if (line.empty() || line[0] == '#') {
      continue;
    }
    const std::string where = LineWhere(images_path, i);
    const std::vector<std::string> tokens = internal::SplitWhitespace(line);
    core::Require(tokens.size() >= 10, where,
                  "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, got " +
                      std::to_string(tokens.size()) + " fields");
    ColmapImage image;
    image.image_id = ParseInt(tokens[0], where + ": IMAGE_ID");
    core::Require(image_ids.insert(image.image_id).second, where + ": IMAGE_ID",
                  "image id " + std::to_string(image.image_id) + " appears twice");
    static const char* const kPose[] = {"QW", "QX", "QY", "QZ", "TX", "TY", "TZ"};
    double pose[7];
    for (int k = 0; k < 7; ++k) {
      pose[k] = ParseDouble(tokens[1 + k], where + ": " + kPose[k]);
    }
    image.camera_id = ParseInt(tokens[8], where + ": CAMERA_ID");
    image.name = tokens[9];
    for (size_t k = 10; k < tokens.size(); ++k) {
      image.name += " " + tokens[k];
    }

    const auto camera = cameras.find(image.camera_id);
    core::Require(camera != cameras.end(), where + ": CAMERA_ID",
                  "camera " + std::to_string(image.camera_id) + " is not in " + cameras_path);
    Eigen::Quaterniond q(pose[0], pose[1], pose[2], pose[3]);
    const double norm = q.norm();
    core::Require(std::abs(norm - 1.0) <= 1e-3, where + ": QW QX QY QZ",
                  "quaternion must have norm 1 (to 1e-3), got " + FormatDouble(norm));
    q.normalize();

    image.camera = camera->second.intrinsics;
    image.camera.id = image.name;
    image.camera.rotation = q.toRotationMatrix();
    image.camera.translation_mm = Eigen::Vector3d(pose[4], pose[5], pose[6]) * options.mm_per_unit;
    image.distortion_fit = camera->second.fit;
    image.camera.Check(where);

    // The next line, whatever it holds, is this image's POINTS2D line (as in COLMAP).
    if (i + 1 < lines.size()) {
      ++i;
      image.num_points2d = CheckPointsLine(lines[i], LineWhere(images_path, i));
    }
    images.push_back(std::move(image));
  }
  return images;
}

std::vector<RadialFitReport> WriteColmapModel(const std::string& folder,
                                              const std::vector<TsaiCamera>& cameras,
                                              const ColmapWriteOptions& options) {
  options.Check();
  const std::string cameras_path = folder + "/cameras.txt";
  const std::string images_path = folder + "/images.txt";
  const std::string points_path = folder + "/points3D.txt";
  std::string cameras_text =
      "# Camera list with one line of data per camera:\n"
      "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
      "# Number of cameras: " +
      std::to_string(cameras.size()) + "\n";
  std::string images_text =
      "# Image list with two lines of data per image:\n"
      "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
      "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
      "# Number of images: " +
      std::to_string(cameras.size()) + ", mean observations per image: 0\n";
  std::vector<RadialFitReport> reports;
  std::set<std::string> names;
  for (size_t i = 0; i < cameras.size(); ++i) {
    const TsaiCamera& camera = cameras[i];
    const std::string where = Where(images_path, "camera '" + camera.id + "'");
    camera.Check(where);
    core::Require(!camera.id.empty() && !HasWhitespace(camera.id), where,
                  "the id is written as the image NAME: must be non-empty without white space");
    core::Require(names.insert(camera.id).second, where, "id appears twice");

    RadialFitReport report;
    const PinholeCamera pinhole = PinholeFromTsai(camera, options.pinhole, &report);
    reports.push_back(report);
    const double fx = pinhole.K(0, 0), fy = pinhole.K(1, 1);
    const double cx = pinhole.K(0, 2) + kColmapPixelOffset;
    const double cy = pinhole.K(1, 2) + kColmapPixelOffset;
    std::string model;
    std::vector<double> params;
    if (camera.kappa1_per_mm2 == 0.0) {
      model = "PINHOLE";
      params = {fx, fy, cx, cy};
    } else if (std::abs(fx - fy) <= 1e-12 * fx) {
      model = options.pinhole.fit_k2 ? "RADIAL" : "SIMPLE_RADIAL";
      params = {fx, cx, cy, pinhole.k1};
      if (options.pinhole.fit_k2) {
        params.push_back(pinhole.k2);
      }
    } else {
      model = "OPENCV";
      params = {fx, fy, cx, cy, pinhole.k1, pinhole.k2, 0.0, 0.0};
    }
    const int id = static_cast<int>(i + 1);
    std::string line = std::to_string(id);
    for (const std::string& field :
         {model, std::to_string(camera.width_px), std::to_string(camera.height_px)}) {
      line += ' ';
      line += field;
    }
    for (const double value : params) {
      line += ' ';
      line += FormatDouble(value);
    }
    cameras_text += line + "\n";

    Eigen::Quaterniond q(camera.rotation);
    if (q.w() < 0.0) {
      q.coeffs() *= -1.0;  // one canonical sign
    }
    const Eigen::Vector3d t = camera.translation_mm / options.mm_per_unit;
    images_text += std::to_string(id) + " " + FormatDouble(q.w()) + " " + FormatDouble(q.x()) +
                   " " + FormatDouble(q.y()) + " " + FormatDouble(q.z()) + " " +
                   FormatDouble(t.x()) + " " + FormatDouble(t.y()) + " " + FormatDouble(t.z()) +
                   " " + std::to_string(id) + " " + camera.id + "\n\n";
  }
  internal::WriteTextFile(cameras_path, cameras_text);
  internal::WriteTextFile(images_path, images_text);
  internal::WriteTextFile(points_path,
                          "# 3D point list with one line of data per point:\n"
                          "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, "
                          "POINT2D_IDX)\n"
                          "# Number of points: 0, mean track length: 0\n");
  return reports;
}

}  // namespace dome::geometry
