// Finding calibration points in images (seed §2.2: "we then extract the image
// projections of these 3D points").
//
//  * Dot targets (the synthetic dome's 3D object and floor marks, calib/target.h):
//    dark blobs on a bright background are found against a local white level (a grey
//    max filter), located to sub-pixel precision by their darkness-weighted centroid,
//    and matched to target ids by growing each square grid of the layout from its key
//    marker (the blob markedly heavier than its neighbours): the key's neighbours
//    seed the grid's two axes -- the orientation is fixed because the camera sees the
//    dotted face from the side its normal points to, so in image coordinates (y down)
//    the axes turn clockwise (cross(i-axis, j-axis) < 0) -- and every further dot is
//    predicted by extrapolating its row or column (robust to lens distortion), or by
//    the grid's homography, and accepted only within a fraction of the local pitch.
//    With several grids (the 3 plates of the object) the assignment of found grids to
//    the target's grids is the one whose 3D-2D projective fit (DLT) is best. The true
//    image points are never used.
//  * Chessboards: OpenCV's findChessboardCorners + cornerSubPix.
//
// Image coordinates: pixels, pixel centres at integers, (0, 0) the centre of the
// top-left pixel (geometry/tsai_camera.h; OpenCV's convention too).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "calib/target.h"

namespace dome::calib {

struct DotDetectorOptions {
  int background_radius_px = 6;  // radius of the closing that gives the local white level, px
  double min_contrast = 25.0;   // darkness below the local white level for a dot pixel, grey levels
  int max_blob_area_px = 600;   // larger dark regions are not dots, px^2
  double key_mass_ratio = 1.3;  // key marker: its darkness mass over its neighbours' median
  double match_tolerance = 0.15;  // accept a dot within this fraction of the local grid pitch
  int min_grid_points = 6;        // a grid with fewer matched dots is dropped (and reported)
  void Check() const;             // throws core::InputError naming the option
};

struct Blob {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // px, darkness-weighted centroid
  double mass = 0.0;                                 // summed darkness (grey levels x pixels)
  int area_px = 0;
  bool cut = false;  // touches the image border (centroid unreliable)
};

// Dark blobs of an 8-bit grey image (CV_8UC1).
std::vector<Blob> DetectBlobs(const cv::Mat& gray, const DotDetectorOptions& options);

struct DotDetection {
  std::vector<ImagePoint> points;    // matched dots, by target id
  int blobs = 0;                     // dark blobs found
  int grids_found = 0;               // of the layout's grids
  std::vector<int> missing_ids;      // grid ids not found in the image (not plain marks)
  std::vector<int> conflicting_ids;  // dots claimed by two grids (dropped, reported)
  std::string BriefReport() const;
};

// Finds and identifies the dots of `target` in `gray`. `where` names the image for
// errors. Throws core::InputError when no key marker or no grid can be found.
DotDetection DetectDotTarget(const cv::Mat& gray, const Target& target, const GridLayout& layout,
                             const DotDetectorOptions& options, const std::string& where);

struct ChessboardOptions {
  int inner_corners_x = 9;    // inner corners per row
  int inner_corners_y = 6;    // inner corners per column
  int subpix_window_px = 11;  // cornerSubPix window side (2 * half + 1), px
  void Check() const;
};

// Inner corners of a chessboard, row-major (OpenCV's order), refined to sub-pixel.
// Returns false when the board is not found.
bool DetectChessboard(const cv::Mat& gray, const ChessboardOptions& options,
                      std::vector<Eigen::Vector2d>* corners);

}  // namespace dome::calib
