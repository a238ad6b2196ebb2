// Photo-consistency carving of a visual hull (space carving: Kutulakos and Seitz, "A
// theory of shape by space carving", IJCV 2000), for the few far-apart cameras of a
// sparse rig, where the hull of a few people holds ghost volume many times theirs and
// stereo between such views matches too little to carve it.
//
// The hull (silhouette/hull.h) is sampled on a grid of cubic cells; a kept cell with a
// face on a cell that is not kept is on the surface. Each sweep carves every surface
// cell that at least two cameras see and no two of them in agreeing colours: in each
// camera a surface cell is seen when it is in front of it, inside its image and at most
// a depth tolerance behind the nearest surface cell over its pixel (a z-buffer of the
// surface cells); its colour there is the image's box-filtered colour at its centre's
// pixel. A real surface shows one colour to every camera that sees it (up to noise and
// the cameras' responses); a ghost's surface shows each camera a different place, often
// a different person. Carving uncovers cells behind, so the sweeps repeat until one
// carves little. Cells the hull never held stay as they are: only carving moves the
// border, the hull's own border stays the hull's.
//
// Frames and units: world mm; images as recorded (distorted), the cameras' sizes,
// CV_8UC3 in any channel order (one order for all); colour distances in 8-bit levels.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "geometry/tsai_camera.h"
#include "silhouette/hull.h"

namespace dome::silhouette {

struct PhotoHullOptions {
  // Edge of a cell, mm (> 0). Callers derive it from the reconstruction's voxel (fusion:
  // two voxels, pipeline/jobs.cc).
  double cell_mm = 20.0;
  // Colours of one cell in two cameras agree when they differ by at most this (Euclidean
  // over the three channels, 8-bit levels, after the box filter; > 0). About
  // 23 levels a channel: several times a camera's noise (5-9 levels on Panoptic's
  // footage, the masks' estimate), and above the differences of the cameras' colour
  // responses and of a surface seen from directions 50-120 degrees apart. (Panoptic's
  // leave-one-out IoU was the same within 0.001 at 25 and 60: README "Silhouettes".)
  double max_colour_distance = 40.0;
  // Side of the box filter over each image before sampling, pixels (odd, >= 1): a 5 x 5
  // mean averages a camera's noise down by five, and a cell's colour is then that of the
  // patch around its centre's pixel rather than of one pixel of it.
  int colour_box_px = 5;
  // The z-buffers have one pixel per this many image pixels a side (>= 1); each cell is
  // drawn over its footprint (a Panoptic cell of 17 mm at 3 m covers about two of them),
  // so that cells behind do not show between those in front.
  int visibility_px = 4;
  // A cell is seen by a camera when it lies at most this many cells behind the nearest
  // surface cell over its pixel (> 0): the cell beside it on a slanted surface.
  double depth_tolerance_cells = 1.5;
  // The sweeps stop when one carves fewer than this fraction of the surface's cells
  // ([0, 1)), or after max_sweeps (>= 1).
  double stop_fraction = 0.01;
  int max_sweeps = 10;
  // After the sweeps, the kept cells are opened (eroded, then dilated) by a ball of this
  // radius, in cells (>= 0; 0: no opening), and what the opening removed is carved
  // unless a camera's silhouette needs it: a removed cell stays when it projects where
  // the kept cells cover that camera's image and the opened ones do not (the z-buffers'
  // pixels, each cell drawn over its footprint). The cones of a few far-apart cameras
  // leave thin ghost wedges on the people and between them that no two cameras see, so
  // colours cannot carve them; a wedge is never needed, as the person whose silhouette
  // made it covers its pixels in every camera, while an arm or a leg that only it shows
  // in some camera is kept however thin. Panoptic's leave-one-out IoU (README
  // "Silhouettes", cells of 17 mm): 0.576 without, 0.586, 0.588 and 0.582 with radii of 2,
  // 3 and 4 cells; opening without the silhouettes' check (an offline study of the plain
  // hull) lost the thinner third person of the first instant.
  int open_radius_cells = 3;
  int num_threads = 0;  // <= 0: all hardware threads
  // Throws core::InputError naming the field when out of range.
  void Check() const;
};

struct PhotoHullStats {
  int64_t hull_cells = 0;    // cells whose centre is in the visual hull
  int64_t carved_cells = 0;  // of them, carved (by colour or by the opening)
  int sweeps = 0;
  int64_t opened_cells = 0;    // carved by the opening (open_radius_cells)
  int64_t restored_cells = 0;  // removed by the opening, kept for a silhouette
};

class PhotoHull {
 public:
  // The hull's cells over the box [lo_mm, hi_mm] (world), carved with `images` (one per
  // camera of `cameras`, the hull's cameras in its order). Throws core::InputError
  // naming the camera when an image is not CV_8UC3 of its camera's size, or the counts
  // differ from the hull's.
  PhotoHull(const VisualHull& hull, const std::vector<geometry::TsaiCamera>& cameras,
            const std::vector<cv::Mat>& images, const Eigen::Vector3d& lo_mm,
            const Eigen::Vector3d& hi_mm, const PhotoHullOptions& options);

  // Signed distance to the border of what was carved, mm, positive on the carved side:
  // trilinear over the cell centres of -cell_mm / 2 (kept or never in the hull) and
  // +cell_mm / 2 (carved), so within half a cell of the border and 0 on it; -cell_mm / 2
  // far from any carved cell and outside the grid.
  double CarvedDistanceMm(const Eigen::Vector3d& world_mm) const;
  const PhotoHullStats& stats() const { return stats_; }

 private:
  Eigen::Vector3d origin_mm_;  // the first cell's min corner
  double cell_mm_ = 0;
  int nx_ = 0, ny_ = 0, nz_ = 0;
  std::vector<uint8_t> carved_;  // per cell, x fastest: 1 = carved
  PhotoHullStats stats_;
};

}  // namespace dome::silhouette
