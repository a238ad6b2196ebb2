// Speckle removal (stereo/speckle.h): pieces are 4-connected runs of valid depths whose
// neighbours differ by at most the step; the small ones go, with their reliability.
#include "stereo/speckle.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "stereo/multi_baseline.h"
#include "stereo/stereo_test_util.h"
#include "testing/expect_error.h"

namespace dome::stereo {
namespace {

// 60 x 40 px: a 30 x 40 ramp (0.01 mm a column) on the left; a 5 x 5 island at the
// ramp's depth, cut off by invalid pixels; a 6 x 6 block touching the ramp 5 mm behind.
cv::Mat Scene() {
  cv::Mat d(40, 60, CV_32FC1, cv::Scalar(0));
  for (int y = 0; y < 40; ++y) {
    for (int x = 0; x < 30; ++x) d.at<float>(y, x) = 100.0f + 0.01f * x;
  }
  d(cv::Rect(40, 5, 5, 5)).setTo(100.0f);
  d(cv::Rect(30, 20, 6, 6)).setTo(105.3f);
  return d;
}

SpeckleOptions Options(int area) {
  SpeckleOptions o;
  o.min_area_px = area;
  o.max_step_mm = 0.1;
  return o;
}

TEST(Speckle, SmallPiecesGoWithTheirReliability) {
  cv::Mat d = Scene(), r(d.size(), CV_32FC1, cv::Scalar(2.0f));
  r.setTo(0.0f, d == 0);
  EXPECT_EQ(RemoveSpeckles(Options(100), &d, &r), 25 + 36);
  EXPECT_EQ(cv::countNonZero(d), 30 * 40);
  EXPECT_EQ(cv::countNonZero(d(cv::Rect(0, 0, 30, 40))), 30 * 40);
  EXPECT_EQ(cv::countNonZero(r), 30 * 40);
  EXPECT_EQ(cv::norm(d(cv::Rect(0, 0, 30, 40)), Scene()(cv::Rect(0, 0, 30, 40)), cv::NORM_INF), 0);

  // 30 px: the island (25) goes, the block behind the ramp (36) stays.
  d = Scene();
  EXPECT_EQ(RemoveSpeckles(Options(30), &d, nullptr), 25);
  EXPECT_EQ(cv::countNonZero(d(cv::Rect(40, 5, 5, 5))), 0);
  EXPECT_EQ(cv::countNonZero(d(cv::Rect(30, 20, 6, 6))), 36);
  // Off: nothing changes.
  d = Scene();
  EXPECT_EQ(RemoveSpeckles(SpeckleOptions{}, &d, nullptr), 0);
  EXPECT_EQ(cv::norm(d, Scene(), cv::NORM_INF), 0);
}

TEST(Speckle, StepsAreBetweenNeighboursNotAcrossThePiece) {
  // A staircase of 40-px columns, each `rise` mm behind the last: one piece of 1600 px
  // while the rise is within the step, 40 pieces of 40 px beyond it.
  for (const auto& [rise, left] : {std::pair{0.09f, 40 * 40}, std::pair{0.11f, 0}}) {
    cv::Mat d(40, 40, CV_32FC1);
    for (int y = 0; y < 40; ++y) {
      for (int x = 0; x < 40; ++x) d.at<float>(y, x) = 200.0f + rise * x;
    }
    RemoveSpeckles(Options(41), &d, nullptr);
    EXPECT_EQ(cv::countNonZero(d), left) << "rise " << rise;
  }
}

TEST(Speckle, TheScanOrderDoesNotMatter) {
  cv::Mat d = Scene(), t;
  cv::transpose(Scene(), t);
  RemoveSpeckles(Options(30), &d, nullptr);
  RemoveSpeckles(Options(30), &t, nullptr);
  cv::transpose(t, t);
  EXPECT_EQ(cv::norm(d, t, cv::NORM_INF), 0);
}

// The pieces of a flood fill from each unvisited valid pixel (the definition, written
// the plain way): the removal must clear exactly the pixels of its small pieces.
cv::Mat FloodFillKept(const cv::Mat& d, int min_area, float step) {
  cv::Mat seen(d.size(), CV_8UC1, cv::Scalar(0)), kept = d.clone();
  for (int y0 = 0; y0 < d.rows; ++y0) {
    for (int x0 = 0; x0 < d.cols; ++x0) {
      if (seen.at<uint8_t>(y0, x0) || !(d.at<float>(y0, x0) > 0)) continue;
      std::vector<cv::Point> piece = {{x0, y0}};
      seen.at<uint8_t>(y0, x0) = 1;
      for (size_t i = 0; i < piece.size(); ++i) {
        const cv::Point p = piece[i];
        for (const cv::Point q : {p + cv::Point(1, 0), p - cv::Point(1, 0), p + cv::Point(0, 1),
                                  p - cv::Point(0, 1)}) {
          if (q.x < 0 || q.y < 0 || q.x >= d.cols || q.y >= d.rows || seen.at<uint8_t>(q))
            continue;
          if (d.at<float>(q) > 0 && std::abs(d.at<float>(q) - d.at<float>(p)) <= step) {
            seen.at<uint8_t>(q) = 1;
            piece.push_back(q);
          }
        }
      }
      if (int(piece.size()) < min_area)
        for (const cv::Point& p : piece) kept.at<float>(p) = 0;
    }
  }
  return kept;
}

TEST(Speckle, ThePiecesAreThoseOfAFloodFill) {
  // Noisy maps of steps, holes, spirals of a piece that winds back on itself, and
  // non-finite depths, against the plain flood fill.
  cv::RNG rng(7);
  for (int trial = 0; trial < 40; ++trial) {
    const int w = 17 + trial * 3, h = 11 + trial * 2;
    cv::Mat d(h, w, CV_32FC1);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const double u = rng.uniform(0.0, 1.0);
        float v = 100.0f + 0.3f * float((x / 5 + y / 4) % 3) + float(rng.uniform(0.0, 0.12));
        if (u < 0.25 + 0.01 * (trial % 20)) v = 0;
        if (u > 0.995) v = std::numeric_limits<float>::quiet_NaN();
        if (u > 0.99 && u <= 0.995) v = std::numeric_limits<float>::infinity();
        d.at<float>(y, x) = v;
      }
    }
    for (int min_area : {2, 5, 30, 200}) {
      cv::Mat got = d.clone(), r(d.size(), CV_32FC1, cv::Scalar(1.0f));
      const int64_t removed = RemoveSpeckles(Options(min_area), &got, &r);
      const cv::Mat want = FloodFillKept(d, min_area, 0.1f);
      int64_t cleared = 0;
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          const float g = got.at<float>(y, x), e = want.at<float>(y, x);
          ASSERT_TRUE(g == e || (std::isnan(g) && std::isnan(e)))
              << "trial " << trial << " area " << min_area << " at " << x << "," << y;
          const bool gone = (d.at<float>(y, x) > 0) && g == 0;
          cleared += gone;
          EXPECT_EQ(r.at<float>(y, x), gone ? 0.0f : 1.0f);
        }
      }
      EXPECT_EQ(removed, cleared) << "trial " << trial << " area " << min_area;
    }
  }
}

TEST(Speckle, BadOptionsAreNamed) {
  cv::Mat d = Scene();
  SpeckleOptions o;
  o.min_area_px = -1;
  dome::testing::ExpectInputError([&] { RemoveSpeckles(o, &d, nullptr); },
                                  {"speckle_area_px", "-1"});
  o.min_area_px = 10;
  o.max_step_mm = 0;
  dome::testing::ExpectInputError([&] { RemoveSpeckles(o, &d, nullptr); }, {"speckle_step_mm"});
  StereoOptions so;
  so.speckle = o;
  dome::testing::ExpectInputError([&] { so.Check(); }, {"speckle_step_mm"});
}

TEST(Speckle, ComputeDepthRemovesThemFromEachRangeImage) {
  const StereoInput in = testing::PlaneStereoInput(2000.0, true, {{120, 0}, {0, 90}}, 6.0, 11,
                                                   320, 240, 400.0);
  StereoOptions o;
  o.window_sizes_px = {3, 9};
  o.num_threads = 2;
  o.min_uniqueness = 0.0;  // noisy small windows: speckles to remove
  const StereoResult plain = ComputeDepth(in, o);
  o.speckle = Options(200);
  o.speckle.max_step_mm = 20.0;  // a tenth of a level at 2 m
  const StereoResult filtered = ComputeDepth(in, o);
  ASSERT_EQ(filtered.range_images.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    RangeImage expected = plain.range_images[k];
    const int64_t removed =
        RemoveSpeckles(o.speckle, &expected.depth_mm, &expected.reliability);
    const RangeImage& got = filtered.range_images[k];
    EXPECT_EQ(cv::norm(got.depth_mm, expected.depth_mm, cv::NORM_INF), 0) << k;
    EXPECT_EQ(cv::norm(got.reliability, expected.reliability, cv::NORM_INF), 0) << k;
    EXPECT_DOUBLE_EQ(got.density, double(cv::countNonZero(expected.depth_mm)) / (320 * 240));
    EXPECT_GT(got.density, 0.5) << k;
    if (k == 0) {
      EXPECT_GT(removed, 0);
    }
  }
}

}  // namespace
}  // namespace dome::stereo
