// Speckle removal for depth maps: drops the small connected pieces of a range image.
//
// A wrong match rarely agrees with its neighbours, so wrong depths come as small
// islands (and as thin skirts past an object's silhouette, where a window that holds
// the object's texture matches at the object's depth beside it); a true surface gives
// large pieces whose neighbouring depths change smoothly. Removing the islands before
// fusion matters beyond their own floaters: their free-space updates also carve away
// the true surface behind them. The rule is OpenCV's filterSpeckles on depth in mm.
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

namespace dome::stereo {

struct SpeckleOptions {
  // Pieces of fewer pixels than this are removed (their depth and reliability set to
  // 0); 0: nothing is removed.
  int min_area_px = 0;
  // Two 4-neighbour pixels belong to one piece when their depths differ by at most
  // this, in mm (> 0 when min_area_px > 0).
  double max_step_mm = 0.0;

  // Throws core::InputError naming "speckle_area_px" or "speckle_step_mm".
  void Check() const;
};

// Removes the pieces of `depth_mm` (CV_32FC1, mm, 0 = invalid) smaller than
// options.min_area_px and zeroes `reliability` (CV_32FC1 of the same size, or empty)
// there. Returns the number of pixels removed. The result does not depend on the order
// of the scan: a piece is the set of pixels connected through valid 4-neighbours
// within max_step_mm.
int64_t RemoveSpeckles(const SpeckleOptions& options, cv::Mat* depth_mm, cv::Mat* reliability);

}  // namespace dome::stereo
