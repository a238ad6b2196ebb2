#include "eval/depth_eval.h"
#include "eval/statistics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "../io/test_util.h"
#include "io/depth_tiff.h"
#include "io/image_io.h"

namespace dome::eval {
namespace {

using ::dome::testing::ExpectInputError;
using ::dome::testing::TempDir;

// 10x10 truth at 1000 mm except a 2-row band without truth; the estimate misses 10
// truth pixels, is off by 0.5, 1.5, 3 or 30 mm elsewhere, and adds values where the
// truth has none.
struct Scene {
  cv::Mat truth = cv::Mat(10, 10, CV_32FC1, cv::Scalar(1000.0f));
  cv::Mat estimate = cv::Mat(10, 10, CV_32FC1, cv::Scalar(0.0f));
  Scene() {
    truth.rowRange(8, 10).setTo(0.0f);  // 20 pixels without truth
    const float offsets[] = {0.5f, -1.5f, 3.0f, 30.0f};
    int k = 0;
    for (int y = 0; y < 8; ++y) {
      for (int x = 0; x < 10; ++x, ++k) {
        if (k < 10) {
          continue;  // 10 truth pixels without an estimate
        }
        estimate.at<float>(y, x) = 1000.0f + offsets[k % 4];
      }
    }
    estimate.at<float>(9, 0) = 500.0f;  // 3 values without truth
    estimate.at<float>(9, 1) = 500.0f;
    estimate.at<float>(8, 5) = 500.0f;
  }
};

TEST(EvaluateDepth, KnownAnswers) {
  const Scene s;
  DepthEvalOptions options;
  options.tolerances_mm = {1.0, 2.0, 5.0};
  const DepthEvalReport r = EvaluateDepth(s.estimate, s.truth, options);
  EXPECT_EQ(r.n_pixels, 100);
  EXPECT_EQ(r.n_gt_valid, 80);
  EXPECT_EQ(r.n_compared, 70);
  EXPECT_EQ(r.n_est_without_gt, 3);
  EXPECT_DOUBLE_EQ(r.density, 70.0 / 80.0);
  // k = 10..79, offset by k % 4: 0 -> 0.5 (17 pixels), 1 -> -1.5 (17), 2 -> 3 (18), 3 -> 30 (18).
  const double n05 = 17, n15 = 17, n3 = 18, n30 = 18;
  EXPECT_NEAR(r.abs_err_mean_mm, (0.5 * n05 + 1.5 * n15 + 3 * n3 + 30 * n30) / 70, 1e-4);
  EXPECT_NEAR(r.bias_mm, (0.5 * n05 - 1.5 * n15 + 3 * n3 + 30 * n30) / 70, 1e-4);
  EXPECT_NEAR(r.rmse_mm, std::sqrt((0.25 * n05 + 2.25 * n15 + 9 * n3 + 900 * n30) / 70), 1e-4);
  EXPECT_DOUBLE_EQ(r.abs_err_median_mm, 3.0);  // sorted: 17 x 0.5, 17 x 1.5, 18 x 3, 18 x 30
  EXPECT_DOUBLE_EQ(r.abs_err_p90_mm, 30.0);
  ASSERT_EQ(r.scores.size(), 3u);
  EXPECT_DOUBLE_EQ(r.scores[0].within, n05 / 70);
  EXPECT_DOUBLE_EQ(r.scores[1].within, (n05 + n15) / 70);
  EXPECT_DOUBLE_EQ(r.scores[2].within, (n05 + n15 + n3) / 70);
  EXPECT_DOUBLE_EQ(r.scores[2].gt_within, (n05 + n15 + n3) / 80);

  const std::string json = ToJson(r);
  for (const char* key : {"\"n_gt_valid\": 80", "\"n_compared\": 70", "\"density\": 0.875",
                          "\"abs_err_median_mm\": 3", "\"within@5mm\": ", "\"gt_within@1mm\": "}) {
    EXPECT_NE(json.find(key), std::string::npos) << key << " in " << json;
  }
}

TEST(EvaluateDepth, MaskRestrictsThePixels) {
  const Scene s;
  cv::Mat mask(10, 10, CV_8UC1, cv::Scalar(0));
  mask.rowRange(5, 10).setTo(255);  // rows 5..7 with truth (30 px), rows 8..9 without
  const DepthEvalReport r = EvaluateDepth(s.estimate, s.truth, {}, mask);
  EXPECT_EQ(r.n_pixels, 50);
  EXPECT_EQ(r.n_gt_valid, 30);
  EXPECT_EQ(r.n_compared, 30);
  EXPECT_EQ(r.n_est_without_gt, 3);
}

TEST(EvaluateDepth, EmptyEstimateAndNoTruth) {
  const cv::Mat zero(4, 4, CV_32FC1, cv::Scalar(0.0f));
  const cv::Mat truth(4, 4, CV_32FC1, cv::Scalar(800.0f));
  const DepthEvalReport r = EvaluateDepth(zero, truth, {});
  EXPECT_EQ(r.n_compared, 0);
  EXPECT_EQ(r.density, 0.0);
  EXPECT_TRUE(std::isnan(r.abs_err_median_mm));
  EXPECT_EQ(r.scores[0].gt_within, 0.0);
  EXPECT_NE(ToJson(r).find("\"abs_err_median_mm\": null"), std::string::npos);
  EXPECT_TRUE(std::isnan(EvaluateDepth(truth, zero, {}).density));
}

TEST(EvaluateDepth, BadInputsNameWhich) {
  const cv::Mat a(4, 4, CV_32FC1, cv::Scalar(1.0f));
  const cv::Mat b(5, 4, CV_32FC1, cv::Scalar(1.0f));
  ExpectInputError([&] { EvaluateDepth(a, b, {}, {}, "est.tif", "gt.tif"); },
                   {"est.tif", "4x4", "gt.tif", "4x5"});
  cv::Mat nan = a.clone();
  nan.at<float>(2, 3) = std::numeric_limits<float>::quiet_NaN();
  ExpectInputError([&] { EvaluateDepth(a, nan, {}, {}, "est.tif", "gt.tif"); },
                   {"gt.tif", "(3, 2)"});
  ExpectInputError([&] { EvaluateDepth(a, a, {}, cv::Mat(4, 4, CV_32FC1), "e", "t", "m.png"); },
                   {"m.png", "8-bit"});
  DepthEvalOptions bad;
  bad.tolerances_mm = {1.0, -2.0};
  ExpectInputError([&] { bad.Check(); }, {"tolerances_mm[1]"});
}

TEST(EvaluateDepthFiles, ReadsTiffPngAndMask) {
  TempDir dir;
  const Scene s;
  io::WriteDepthTiff(dir / "est.tif", s.estimate);
  io::WriteDepthPng16(dir / "gt.png", s.truth);
  cv::Mat mask(10, 10, CV_8UC1, cv::Scalar(255));
  io::WriteImage(dir / "mask.png", mask);
  const DepthEvalReport r =
      EvaluateDepthFiles(dir / "est.tif", dir / "gt.png", {}, dir / "mask.png");
  EXPECT_EQ(r.n_compared, 70);
  EXPECT_EQ(r.estimate, (dir / "est.tif").string());
  ExpectInputError([&] { EvaluateDepthFiles(dir / "none.tif", dir / "gt.png", {}); },
                   {"none.tif", "no such file"});
}

}  // namespace
}  // namespace dome::eval

namespace dome::eval {
namespace {

TEST(FormatG, SpellsThresholdsAsPythonPercentG) {
  EXPECT_EQ(FormatG(0.5), "0.5");
  EXPECT_EQ(FormatG(1.0), "1");
  EXPECT_EQ(FormatG(0.25), "0.25");
  EXPECT_EQ(FormatG(10.0), "10");
}

}  // namespace
}  // namespace dome::eval
