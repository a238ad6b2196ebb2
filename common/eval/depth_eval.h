// A depth map against a ground-truth depth map.
//
// Both maps are io depth maps: CV_32FC1, z along the optical axis in mm, 0 = no value
// (io/depth_tiff.h). Optionally a mask (CV_8UC1, same size; nonzero = evaluate the
// pixel) restricts the comparison, e.g. to the object's silhouette.
//
//  * n_gt_valid: masked pixels where the truth has a value.
//  * n_compared: of those, pixels where the estimate also has a value;
//    density = n_compared / n_gt_valid (the "density of pixels given a value").
//  * Errors over the compared pixels, |estimate - truth| in mm: median, mean, 90th
//    percentile, RMS, and the signed mean (bias, estimate - truth).
//  * For each tolerance t: within@t = fraction of compared pixels with error <= t;
//    gt_within@t = the same count over n_gt_valid, so missing values count as
//    failures (a sparse but accurate map cannot score well on it).
//  * n_est_without_gt: masked pixels where the estimate has a value and the truth
//    has none (hallucinated or simply unverifiable depth).
#pragma once

#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace dome::eval {

struct DepthEvalOptions {
  // Error tolerances, in mm.
  std::vector<double> tolerances_mm = {1.0, 2.0, 5.0, 10.0, 20.0};

  // Throws core::InputError naming the first option out of range.
  void Check() const;
};

struct DepthToleranceScores {
  double tolerance_mm = 0.0;
  double within = 0.0;     // of compared pixels
  double gt_within = 0.0;  // of ground-truth pixels
};

struct DepthEvalReport {
  std::string estimate;  // names of the inputs (file paths when read from files)
  std::string truth;
  int64_t n_pixels = 0;  // pixels in the mask (all pixels without one)
  int64_t n_gt_valid = 0;
  int64_t n_compared = 0;
  int64_t n_est_without_gt = 0;
  double density = 0.0;  // n_compared / n_gt_valid; NaN when no truth
  // Over compared pixels, mm; NaN when none.
  double abs_err_median_mm = 0.0;
  double abs_err_mean_mm = 0.0;
  double abs_err_p90_mm = 0.0;
  double rmse_mm = 0.0;
  double bias_mm = 0.0;
  std::vector<DepthToleranceScores> scores;  // one per tolerance, in the options' order

  std::string BriefReport() const;
};

// Throws core::InputError naming the estimate, truth or mask (by the given names) when
// a map is not a valid depth map, the sizes differ, or the mask is not CV_8UC1.
DepthEvalReport EvaluateDepth(const cv::Mat& estimate_mm, const cv::Mat& truth_mm,
                              const DepthEvalOptions& options, const cv::Mat& mask = cv::Mat(),
                              const std::string& estimate_name = "estimate",
                              const std::string& truth_name = "truth",
                              const std::string& mask_name = "mask");

// Reads the maps with io::ReadDepthMap (.tif float mm or .png 16-bit mm) and the mask,
// if `mask` is not empty, as an 8-bit gray image; errors name the files.
DepthEvalReport EvaluateDepthFiles(const std::filesystem::path& estimate,
                                   const std::filesystem::path& truth,
                                   const DepthEvalOptions& options,
                                   const std::filesystem::path& mask = {});

// One-line JSON: estimate, truth, n_pixels, n_gt_valid, n_compared, n_est_without_gt,
// density, abs_err_median_mm, abs_err_mean_mm, abs_err_p90_mm, rmse_mm, bias_mm,
// within@<t>mm, gt_within@<t>mm (t printed with '%g').
std::string ToJson(const DepthEvalReport& report);

}  // namespace dome::eval
