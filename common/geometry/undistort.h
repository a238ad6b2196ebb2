// Whole-image distortion correction for Tsai cameras.
//
// Two images of one camera:
//  * the distorted image: what the real camera recorded (Tsai model with kappa1);
//  * the ideal image: the same camera with kappa1 = 0 — same width, height, focal
//    length, sx, image centre and sensor, hence the same K (TsaiCamera::K()). It is a
//    pure pinhole image: x ~ K [R | t] X.
// Both use dome's pixel convention (integer coordinates at pixel centres, (0, 0) the
// centre of the top-left pixel; see tsai_camera.h), which is also cv::remap's.
//
// Resampling is cv::remap with bilinear interpolation. OpenCV quantizes the
// fractional sample position to 1/32 pixel (INTER_TAB_SIZE), so a resampled feature is
// placed to about 0.03 px; the tables themselves are float (about 1e-4 px at 2000 px).
// Output pixels whose source falls outside the input image, or (kappa1 < 0) beyond the
// largest radius the model reaches, are 0.
//
// The images may be of any depth and channel count that cv::remap supports (8U, 16U,
// 16S, 32F, 64F; 1 to 4 channels); the output has the input's type.
#pragma once

#include <memory>
#include <opencv2/core.hpp>

#include "geometry/tsai_camera.h"

namespace dome::geometry {

// Per-output-pixel sample positions in the input image, both CV_32FC1 of
// height_px x width_px, as cv::remap takes them. Position -1 marks "no source".
struct RemapTables {
  cv::Mat map_x;
  cv::Mat map_y;
  // Remap of an all-255 8-bit image through these tables (CV_8UC1): 255 where every
  // bilinear tap of an output pixel has data, less where some fall outside the input, 0
  // where none do. Where a resampled image has data, made once with the tables (a
  // hull's "seen", an image without alpha's validity) instead of per image.
  cv::Mat covered;
};

// For every pixel p of the ideal image: DistortPixel(p) in the distorted image.
// camera.Check() must hold (InputError otherwise).
RemapTables BuildUndistortTables(const TsaiCamera& camera);
// The same tables from a process-wide cache keyed by the intrinsics (image size,
// sensor, focal length, kappa1, centre, sx; not the pose), built on first use: a worker
// undistorts each camera's frames in every stereo job it runs, as reference and as
// neighbour. Bounded to about 512 MB of tables (oldest dropped first). Thread-safe.
std::shared_ptr<const RemapTables> SharedUndistortTables(const TsaiCamera& camera);
// For every pixel p of the distorted image: UndistortPixel(p) in the ideal image.
RemapTables BuildDistortTables(const TsaiCamera& camera);

// Resamples `image` through `tables` (bilinear, zero outside). InputError when the
// image is empty, its size differs from the tables' or OpenCV rejects its type.
// Build the tables once per camera and call this per frame.
cv::Mat Remap(const cv::Mat& image, const RemapTables& tables);

// Distorted image (camera's size) -> ideal kappa1 = 0 image with the same K.
cv::Mat UndistortImage(const TsaiCamera& camera, const cv::Mat& distorted);
// Ideal image -> what the camera with kappa1 would have seen (the inverse).
cv::Mat DistortImage(const TsaiCamera& camera, const cv::Mat& ideal);

}  // namespace dome::geometry
