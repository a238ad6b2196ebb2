// Calibration targets and views of TAKE/calib/ (the format is proto/calib.proto, read
// through protobuf's JSON mapping; unknown fields are rejected by name):
//   calib/stage1/target.json   TargetPoints: the 3D calibration object (frame "object")
//   calib/stage1/<camera>.json CalibView: the camera's image of it ("image", relative)
//   calib/stage2/target.json   TargetPoints: the floor marks (frame "world", z = 0)
//   calib/stage2/<camera>.json CalibView
// A view's "points" (true or detected image points) are optional for dome calibrate,
// which detects its own; "target_to_camera" is never used by the calibration.
//
// Dot targets are read as square grids (GridLayout): the points split into G blocks of
// n x n consecutive ids, id = base + n * j + i (i, j = 0 .. n-1 along the grid's two
// axes), each block planar with its key marker (the larger dot) at (i, j) = (0, 0).
// That is how `dome synth` numbers its object (3 plates of 7 x 7) and its floor marks
// (one 5 x 5 grid, ids 0-24). A target may list further plain marks after its grids
// (TargetPoints.grid_points: the first that many points, by id, form the grids): they
// lie in the plane of the grids and are identified from the pose the grids give
// (`dome synth`'s floor marks beyond the central grid, calib/calibrate.h).
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

namespace dome::calib {

struct TargetPoint {
  int id = 0;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();
};

struct Target {
  std::string path;   // file it was read from (for messages)
  std::string frame;  // "object" or "world"
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

struct CalibViewFile {
  std::string path;                // the view's JSON file
  std::string camera;              // camera id
  std::filesystem::path image;     // absolute (resolved against the JSON's folder)
  std::filesystem::path target;    // absolute
  std::vector<ImagePoint> points;  // as stored (truth or a detector's), may be empty
};

// Reads and checks a TargetPoints file. Throws core::InputError naming the file and
// field: unreadable or malformed JSON, a coordinate that is NaN or infinite, a
// duplicate id, no points, a non-positive marker radius.
Target ReadTarget(const std::filesystem::path& path);

// Reads a CalibView file. Throws core::InputError naming the file and field.
CalibViewFile ReadCalibView(const std::filesystem::path& path);

// One square grid of a dot target, in grid order: ids[n * j + i].
struct Grid {
  int n = 0;
  std::vector<int> ids;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // unit, (P(1,0)-P(0,0)) x (P(0,1)-P(0,0))
};

struct GridLayout {
  std::vector<Grid> grids;
  // The plain marks after the grids (ids ascending), in the plane of grid 0 (normal).
  std::vector<int> plain_ids;
};

// The grid layout of a dot target (see the header comment). Throws core::InputError
// naming the target file when its grid points do not form planar square grids, or
// its plain marks do not lie in the grids' plane.
GridLayout InferGridLayout(const Target& target);

}  // namespace dome::calib
