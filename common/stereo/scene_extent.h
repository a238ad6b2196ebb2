// Where the scene is, from the rig and the images alone (no reference geometry): the
// region every camera sees, then the part of it where coarse stereo finds surfaces.
//
// 1. The view centre: the point nearest (least squares) to every camera's optical
//    axis — where a dome, ring or any inward-looking rig converges. Its view radius:
//    for each camera, the radius of the sphere about the centre that stays inside the
//    image (distance to the nearest image edge in pixels x depth / focal length in
//    pixels); the median over the cameras.
// 2. A coarse stereo pass per camera and instant: the greys (GreyImage, so the session's
//    contrast rules apply) block-averaged until the long side is at most
//    coarse_long_side_px, matched with the camera's cluster over the depths of the view
//    sphere grown twice (z along each camera's axis, world mm).
// 3. Each coarse depth becomes a world point; a point is kept when another camera of
//    its cluster has a depth within consistency_px coarse pixels' footprint of the
//    point's depth in that camera (outliers of one camera do not agree with another),
//    and when at least min_view_fraction of all cameras have it inside their image
//    (the region seen in common, not the walls one camera sees alone).
// 5. Each camera's depth range: the depths of the kept points inside its image.
// 4. The box: the points binned in cubic cells (cell_px coarse footprints at the view
//    centre); cells with min_cell_points or more are occupied; the 26-connected pieces
//    of occupied cells holding at least min_piece_fraction of the largest piece's points
//    are the scene's objects (stray matches make small pieces); the box bounds their
//    cells and is grown by margin_fraction of its size on every side.
// World frame and units are the rig's (millimetres). Depth maps of the coarse pass are
// in the ideal (undistorted) cameras, as every range image of multi_baseline.h.
#pragma once

#include <Eigen/Core>
#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "stereo/cluster.h"
#include "stereo/multi_baseline.h"
#include "take/take.h"

namespace dome::stereo {

struct SceneExtentOptions {
  int coarse_long_side_px = 256;      // coarse images' long side at most this, pixels
  int window_px = 7;                  // coarse SSD window side, coarse pixels (odd)
  double min_uniqueness = 0.3;        // coarse matches must be this clearly unique
  double consistency_px = 2.0;        // agreement between cameras, coarse pixels' footprint
  double min_view_fraction = 0.75;    // of all cameras that must have a point in their image
  double cell_px = 4.0;               // occupancy cell edge, coarse pixel footprints
  int min_cell_points = 3;            // points that make a cell occupied
  double min_piece_fraction = 0.002;  // of the largest piece's points a kept piece holds
  // Box grown by this fraction of its size per side. The occupied cells already pad
  // the points by up to a cell; the margin holds what the coarse pass missed at the
  // scene's edges (a rim the coarse window straddles). Where the voxel budget sets the
  // voxel, a larger margin makes it coarser (Robovision: 0.164 mm at 0.1, 0.150 mm at
  // 0.05).
  double margin_fraction = 0.05;
  int max_instants = 3;  // instants looked at, evenly spaced (>= 1)
  int min_points = 200;  // fewer kept points: the view sphere's box is used
  int num_threads = 0;   // 0: all hardware threads

  // Throws core::InputError naming the option ("scene.window_px") when out of range.
  void Check() const;
};

struct SceneExtent {
  Eigen::Vector3d view_centre_mm = Eigen::Vector3d::Zero();  // nearest point to the axes
  double view_radius_mm = 0;      // sphere about it every camera sees (median)
  double median_distance_mm = 0;  // camera centre to view centre, median
  Eigen::Vector3d min_mm = Eigen::Vector3d::Zero(), max_mm = Eigen::Vector3d::Zero();
  int reduction = 1;                  // the coarse pass's image reduction factor
  int64_t points = 0;                 // coarse points kept
  bool from_stereo = false;           // false: the view sphere's box (too few points)
  std::vector<std::string> instants;  // the instants looked at
  // Per camera (rig order), the depths of the kept points it has in its image: their
  // 0.2 .. 99.8 % range widened by margin_fraction of it and two coarse footprints on
  // each end (z along its axis, mm); {0, 0} for a camera that sees none of them.
  std::vector<std::pair<double, double>> camera_depth_mm;
};

// Throws core::InputError when the cameras' axes do not converge (parallel axes, or
// the centre behind most cameras), naming what to give instead (a box).
// `decoded`: frames the caller has already read (frame path -> the image as ReadFrame
// gives it), used instead of reading those files again.
SceneExtent EstimateSceneExtent(const take::Take& take, const std::vector<std::string>& instants,
                                const StereoOptions& greys, const ClusterOptions& cluster,
                                const SceneExtentOptions& options,
                                const std::map<std::string, cv::Mat>& decoded = {});

// Pixel footprint at the scene: the median over cameras of (depth of `point_mm` / focal
// length in pixels), mm per pixel.
double PixelFootprintMm(const geometry::Rig& rig, const Eigen::Vector3d& point_mm);

}  // namespace dome::stereo
