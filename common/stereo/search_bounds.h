// Per-pixel limits of a stereo search, from whatever knows more about the scene than
// the session's depth range: the visual hull of silhouettes (silhouette/hull.h), the
// previous instant's depths. A search with bounds (coarse_to_fine.h ComputeDepthBounded,
// ComputeDepthCoarseToFine) gives no depth where a pixel is not searched, and no depth
// outside a pixel's own bounds.
//
// Grid, frame and units: the reference camera's ideal (distortion-free) pixel grid,
// where stereo matches (multi_baseline.h GreyImage with undistort), width_px x
// height_px; depths z along the reference camera's optical axis, mm.
#pragma once

#include <opencv2/core.hpp>
#include <string>

namespace dome::stereo {

struct SearchBounds {
  // CV_32FC2, per pixel (near, far) in mm. A pixel with near >= far (e.g. (0, 0)) is not
  // searched.
  cv::Mat near_far_mm;

  bool Searched(int x, int y) const {
    const cv::Vec2f b = near_far_mm.at<cv::Vec2f>(y, x);
    return b[0] < b[1];
  }
  // Throws core::InputError naming `where` unless near_far_mm is CV_32FC2 of `size`
  // with finite, non-negative values.
  void Check(cv::Size size, const std::string& where) const;
  // The least near and greatest far over the searched pixels of `rect`; false when none
  // is searched.
  bool Range(const cv::Rect& rect, double* near_mm, double* far_mm) const;
  // The bounding rectangle of the searched pixels of `rect`; empty when none is.
  cv::Rect SearchedRect(const cv::Rect& rect) const;
  // Clears (sets to 0) the depths of `depth_mm` (CV_32FC1, the grid above) and of
  // `reliability` where the pixel is not searched or its depth is outside its bounds.
  // Returns how many depths it cleared.
  int64_t Apply(cv::Mat* depth_mm, cv::Mat* reliability) const;
};

}  // namespace dome::stereo
