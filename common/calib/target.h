// Calibration targets and views of TAKE/calib/ (files: schema/calib_json.h).
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

#include "schema/calib_json.h"

namespace dome::calib {

// The files' records (schema/calib_json.h).
using schema::CalibView;
using schema::ImagePoint;
using schema::ReadCalibView;
using schema::ReadTarget;
using schema::Target;
using schema::TargetPoint;

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
