// The calibration files of TAKE/calib/ (proto/calib.proto, through protobuf's JSON
// mapping; unknown fields are rejected by name):
//   calib/stage1/target.json   TargetPoints: the 3D calibration object (frame "object")
//   calib/stage1/<camera>.json CalibView: the camera's image of it ("image", relative)
//   calib/stage2/target.json   TargetPoints: the floor marks (frame "world", z = 0)
//   calib/stage2/<camera>.json CalibView
// Units: mm for target points, pixels for image points (distorted, pixel centres at
// integers: geometry/tsai_camera.h). How a dot target's ids form grids is calib/target.h.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace dome::schema {

struct TargetPoint {
  int id = 0;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
};

// A TargetPoints file.
struct Target {
  std::string path;         // file it was read from (for messages)
  std::string frame;        // "object" or "world"
  std::string description;  // what the target is and how its points are marked
  double marker_radius_mm = 0.0;
  double key_marker_radius_mm = 0.0;
  std::vector<TargetPoint> points;  // ids unique, coordinates finite
  // How many points, the lowest ids, form the grids; the rest are plain marks. 0 = all.
  int grid_points = 0;

  int Find(int id) const;  // index of the point with this id, or -1
};

struct ImagePoint {
  int id = 0;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
};

// A rigid transform target frame -> camera frame: camera = R * target + t.
struct TargetPose {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
};

// A CalibView file: one calibration image and its image points.
struct CalibView {
  std::string path;              // the view's JSON file
  std::string camera;            // camera id
  std::filesystem::path image;   // read: absolute (resolved against the JSON's folder);
                                 // written: as given (relative to the file's folder)
  std::filesystem::path target;  // the same; default target.json
  std::string source;            // "truth" or the detector's name
  std::optional<TargetPose> target_to_camera;  // the pose the image was taken in, if known
  std::vector<ImagePoint> points;              // as stored (truth or a detector's), may be empty
};

// Reads and checks a TargetPoints file. Throws core::InputError naming the file and
// field: unreadable or malformed JSON, a coordinate that is NaN or infinite, a
// duplicate id, no points, a non-positive marker radius.
Target ReadTarget(const std::filesystem::path& path);
// Reads a CalibView file. Throws core::InputError naming the file and field.
CalibView ReadCalibView(const std::filesystem::path& path);

// The files' JSON (format version 1, every field written).
std::string TargetToJson(const Target& target);
std::string CalibViewToJson(const CalibView& view);

}  // namespace dome::schema
