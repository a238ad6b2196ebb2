// One camera calibrated from 3D-2D correspondences given in a file, as Willson's `ccal`
// (coplanar points, all z = 0) and `ncal` (non-coplanar) programs do: Tsai's
// closed-form initialisation, then Levenberg-Marquardt over every parameter the points
// determine (coplanar points cannot fix sx: it stays 1).
//
// Point file: one correspondence per line, `x y z Xf Yf` (Willson's column order:
// world mm, then the distorted pixel), separated by spaces, tabs or commas; lines
// starting with '#' and blank lines are skipped; a first line of column names (CSV
// header) is skipped when it holds no number.
//
// Error figures (Willson's cal_eval, per point, then mean, standard deviation, max):
//   distorted image plane   |observed pixel - projection of the point|, pixels;
//   undistorted image plane |undistorted observed pixel - ideal projection|, pixels;
//   object space            distance of the point from the ray through the observed
//                           pixel, mm;
//   normalized calibration error (Weng et al. 1992): the mean over points of
//     sqrt(((x^ - x)^2 + (y^ - y)^2) / (z^2 (dpx^2 / f^2 + dpy^2 / f^2) / 12)), with
//     (x, y, z) the point in the camera frame and (x^, y^) the observed pixel's ray at
//     depth z; about 1 when the error is one pixel's quantisation.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "calib/tsai_calibration.h"

namespace dome::calib {

// Throws core::InputError naming the file and line of a malformed row, and the file when
// it holds no correspondence.
std::vector<Correspondence> ReadPointFile(const std::filesystem::path& path);

struct ErrorStats {
  double mean = 0, stddev = 0, max = 0;
};

struct PointCalibration {
  geometry::TsaiCamera camera;  // pose: world -> camera
  bool coplanar = false;
  ErrorStats distorted_px, undistorted_px, object_mm;
  double normalized_error = 0;
  RefineSummary refine;
  // The parameters and figures as Willson's programs print them.
  std::string Report() const;
};

// The camera of `prior` (id, size, sensor constants) from `points` (`where` names them in
// errors). Refuses fewer than 7 points, collinear points, and points that span no volume
// when not all z = 0, each by name.
PointCalibration CalibrateFromPoints(const CameraPrior& prior,
                                     const std::vector<Correspondence>& points,
                                     const std::string& where);

// The figures above for `camera` (its pose) and `points`.
void EvaluatePoints(const geometry::TsaiCamera& camera, const std::vector<Correspondence>& points,
                    PointCalibration* out);

}  // namespace dome::calib
