#include "eval/depth_eval.h"

#include <cmath>
#include <cstdio>
#include <limits>

#include "core/error.h"
#include "core/json.h"
#include "eval/statistics.h"
#include "io/depth_tiff.h"
#include "io/image_io.h"

namespace dome::eval {

void DepthEvalOptions::Check() const {
  for (size_t i = 0; i < tolerances_mm.size(); ++i) {
    core::Require(std::isfinite(tolerances_mm[i]) && tolerances_mm[i] > 0.0,
                  "tolerances_mm[" + std::to_string(i) + "]", "must be a positive number of mm");
  }
}

DepthEvalReport EvaluateDepth(const cv::Mat& estimate_mm, const cv::Mat& truth_mm,
                              const DepthEvalOptions& options, const cv::Mat& mask,
                              const std::string& estimate_name, const std::string& truth_name,
                              const std::string& mask_name) {
  options.Check();
  io::CheckDepthMap(estimate_mm, estimate_name);
  io::CheckDepthMap(truth_mm, truth_name);
  auto size_text = [](const cv::Mat& m) {
    return std::to_string(m.cols) + "x" + std::to_string(m.rows);
  };
  core::Require(estimate_mm.size() == truth_mm.size(), estimate_name,
                "is " + size_text(estimate_mm) + " but the truth " + truth_name + " is " +
                    size_text(truth_mm));
  if (!mask.empty()) {
    core::Require(mask.type() == CV_8UC1, mask_name, "a mask must be single-channel 8-bit");
    core::Require(mask.size() == truth_mm.size(), mask_name,
                  "is " + size_text(mask) + " but the depth maps are " + size_text(truth_mm));
  }

  DepthEvalReport report;
  report.estimate = estimate_name;
  report.truth = truth_name;
  std::vector<double> abs_err;
  double sum_signed = 0.0, sum_sq = 0.0;
  for (int y = 0; y < truth_mm.rows; ++y) {
    const float* est = estimate_mm.ptr<float>(y);
    const float* gt = truth_mm.ptr<float>(y);
    const uint8_t* m = mask.empty() ? nullptr : mask.ptr<uint8_t>(y);
    for (int x = 0; x < truth_mm.cols; ++x) {
      if (m != nullptr && m[x] == 0) {
        continue;
      }
      ++report.n_pixels;
      const bool has_gt = gt[x] > 0.0f, has_est = est[x] > 0.0f;
      if (!has_gt) {
        report.n_est_without_gt += has_est ? 1 : 0;
        continue;
      }
      ++report.n_gt_valid;
      if (!has_est) {
        continue;
      }
      const double e = static_cast<double>(est[x]) - gt[x];
      abs_err.push_back(std::abs(e));
      sum_signed += e;
      sum_sq += e * e;
    }
  }
  report.n_compared = static_cast<int64_t>(abs_err.size());
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  report.density =
      report.n_gt_valid > 0 ? static_cast<double>(report.n_compared) / report.n_gt_valid : kNaN;
  const double n = static_cast<double>(report.n_compared);
  report.bias_mm = report.n_compared > 0 ? sum_signed / n : kNaN;
  report.rmse_mm = report.n_compared > 0 ? std::sqrt(sum_sq / n) : kNaN;
  report.abs_err_mean_mm = Mean(abs_err);
  for (const double t : options.tolerances_mm) {
    DepthToleranceScores s;
    s.tolerance_mm = t;
    s.within = FractionAtMost(abs_err, t);
    s.gt_within = report.n_gt_valid > 0
                      ? (report.n_compared > 0 ? s.within * n / report.n_gt_valid : 0.0)
                      : kNaN;
    report.scores.push_back(s);
  }
  report.abs_err_median_mm = Quantile(abs_err, 0.5);
  report.abs_err_p90_mm = Quantile(abs_err, 0.9);
  return report;
}

DepthEvalReport EvaluateDepthFiles(const std::filesystem::path& estimate,
                                   const std::filesystem::path& truth,
                                   const DepthEvalOptions& options,
                                   const std::filesystem::path& mask) {
  options.Check();
  const cv::Mat est = io::ReadDepthMap(estimate);
  const cv::Mat gt = io::ReadDepthMap(truth);
  const cv::Mat m = mask.empty() ? cv::Mat() : io::ReadImage(mask, io::ImageMode::kGray8);
  return EvaluateDepth(est, gt, options, m, estimate.string(), truth.string(), mask.string());
}

std::string DepthEvalReport::BriefReport() const {
  char buf[512];
  std::snprintf(buf, sizeof(buf),
                "depth: %lld of %lld ground-truth pixels given a value (density %.4f), %lld "
                "without truth\n|error|: median %.4g mm, mean %.4g mm, p90 %.4g mm, RMS %.4g "
                "mm, bias %.4g mm",
                static_cast<long long>(n_compared), static_cast<long long>(n_gt_valid), density,
                static_cast<long long>(n_est_without_gt), abs_err_median_mm, abs_err_mean_mm,
                abs_err_p90_mm, rmse_mm, bias_mm);
  std::string out = buf;
  for (const DepthToleranceScores& s : scores) {
    std::snprintf(buf, sizeof(buf), "\n  <= %g mm: %.4f of compared, %.4f of truth", s.tolerance_mm,
                  s.within, s.gt_within);
    out += buf;
  }
  return out;
}

std::string ToJson(const DepthEvalReport& r) {
  core::Json json = {{"estimate", r.estimate},
                     {"truth", r.truth},
                     {"n_pixels", r.n_pixels},
                     {"n_gt_valid", r.n_gt_valid},
                     {"n_compared", r.n_compared},
                     {"n_est_without_gt", r.n_est_without_gt},
                     {"density", r.density},
                     {"abs_err_median_mm", r.abs_err_median_mm},
                     {"abs_err_mean_mm", r.abs_err_mean_mm},
                     {"abs_err_p90_mm", r.abs_err_p90_mm},
                     {"rmse_mm", r.rmse_mm},
                     {"bias_mm", r.bias_mm}};
  for (const DepthToleranceScores& s : r.scores) {
    const std::string t = FormatG(s.tolerance_mm);
    json["within@" + t + "mm"] = s.within;
    json["gt_within@" + t + "mm"] = s.gt_within;
  }
  return core::DumpJson(json);
}

}  // namespace dome::eval
