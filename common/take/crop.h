// Cropping a take to a region of interest (`dome import ... --crop-box`).
//
// Each frame is cut to the bounding rectangle of where a world box projects in it
// (plus a margin, e.g. half a stereo window) and the camera's image centre moves with
// the cut (cx_px -= x0, cy_px -= y0; focal length, sensor pitch and distortion stay),
// so every world point projects onto the same image content as before. Stereo and
// fusion then handle only pixels that can see the box: when the volume is that box,
// nothing they could reconstruct is lost, and the stereo cost is proportional to the
// pixels kept.
//
// Frames: world mm (take/rig.h); rectangles in the original image's pixels.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <opencv2/core.hpp>

#include "geometry/tsai_camera.h"

namespace dome::take {

struct CropBox {
  Eigen::Vector3d min_mm = Eigen::Vector3d::Zero();  // world corner, mm
  Eigen::Vector3d max_mm = Eigen::Vector3d::Zero();  // opposite corner, mm (> min_mm)
  int margin_px = 16;  // pixels kept around the box's projection on every side

  // Throws core::InputError naming `where` when the box is empty or not finite, or the
  // margin is negative.
  void Check(const std::string& where) const;
};

// The part of `camera`'s image where the box projects, grown by the margin and clipped
// to the image. Points of the box behind the camera are ignored; empty when no part of
// the box projects inside the image.
cv::Rect BoxImageRect(const geometry::TsaiCamera& camera, const CropBox& box);

// The pixels [lo_u, hi_u] x [lo_v, hi_v] of `camera`'s image (pixel centres, may reach
// outside it) grown by `margin_px` on every side and clipped to the image: whole pixels
// from floor(lo - margin) to ceil(hi + margin); empty when nothing is left inside.
cv::Rect GrownPixelRect(const geometry::TsaiCamera& camera, double lo_u, double lo_v, double hi_u,
                        double hi_v, double margin_px);

// The camera of the sub-image `rect` (inside the image, not empty).
geometry::TsaiCamera CropCamera(const geometry::TsaiCamera& camera, const cv::Rect& rect);

struct CropSummary {
  int cameras_cropped = 0;      // cameras whose frames were cut
  double pixel_fraction = 1.0;  // pixels kept / pixels before, over all cameras
};

// Crops every frame of the take at `dir` and rewrites its rig.json. A camera that does
// not see the box keeps its whole image. Refuses (InputError) takes with synthetic
// ground-truth depth maps, whose size is the uncropped one.
CropSummary CropTakeToBox(const std::filesystem::path& dir, const CropBox& box);

}  // namespace dome::take
