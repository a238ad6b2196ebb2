// Multi-view consistency of range images, before fusion: a depth sample is kept only
// when range images of other cameras see a surface at the same place. Stereo on real
// photographs leaves a few percent of gross mismatches (tens of mm off) that fusion
// would turn into floating blobs and tunnels; a mismatch is rarely repeated by the
// independent matching of other cameras, a true surface is.
//
// For a valid sample (pixel p, depth z) of camera A: X = A.BackProjectAtDepth(p, z)
// (world mm). For every range image of another camera B (a different camera id; further
// windows of A do not count) X is projected into B; B *agrees* when the nearest pixel
// to the projection is valid and its depth differs from X's camera-z in B by at most
// tolerance_mm. The sample is kept when at least min_views images agree. An image of B
// agrees at most once per sample, whatever its windows.
//
// Units: depths are z along each camera's optical axis, mm, 0 = invalid
// (fusion/integrate.h RangeImage). The result depends only on the images and the
// options (every sample is tested on its own), so it is deterministic.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "fusion/integrate.h"

namespace dome::fusion {

struct ConsistencyOptions {
  int min_views = 1;          // other cameras that must agree (count, >= 1)
  double tolerance_mm = 1.0;  // largest depth difference seen from the other camera, mm
  int num_threads = 0;        // <= 0: all hardware threads

  // Throws core::InputError naming the first option out of range.
  void Check() const;
};

// The depth maps of `images` (same order) with every sample that fails the test set to
// 0. The images are checked first (CheckRangeImage).
std::vector<cv::Mat> KeepConsistentDepth(const std::vector<RangeImage>& images,
                                         const ConsistencyOptions& options);

}  // namespace dome::fusion
