// Temporal search bounds (stereo/temporal_bounds.h): still tiles with previous depths
// are searched around them with the stated margin; changed tiles and tiles the
// previous instant knew too little of are searched whole; the change threshold follows
// the image's own noise; bad sizes are named.
#include "stereo/temporal_bounds.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>

#include "testing/expect_error.h"

namespace dome::stereo {
namespace {

constexpr double kZMin = 1000, kZMax = 5000;
constexpr int kLevels = 101;

// 64x48 greys of uniform noise (sigma ~ `noise` greys) around a ramp.
cv::Mat Grey(int seed, double noise) {
  cv::Mat g(48, 64, CV_32FC1);
  cv::RNG rng{uint64_t(seed)};
  for (int y = 0; y < g.rows; ++y)
    for (int x = 0; x < g.cols; ++x) g.at<float>(y, x) = float(2 * x + y + rng.gaussian(noise));
  return g;
}

RangeImage Plane(float z_mm) {
  RangeImage r;
  r.window_px = 7;
  r.depth_mm = cv::Mat(48, 64, CV_32FC1, cv::Scalar(z_mm));
  r.reliability = cv::Mat(48, 64, CV_32FC1, cv::Scalar(1));
  return r;
}

// Tiles of 16 px: 4 x 3 of them in the 64 x 48 greys.
TemporalBoundsOptions Options16() {
  TemporalBoundsOptions o;
  o.tile_px = 16;
  return o;
}

// The inverse-depth margin of `levels` levels.
double Margin(double levels) { return levels * (1 / kZMin - 1 / kZMax) / (kLevels - 1); }

TEST(TemporalBounds, StillTilesAreSearchedAroundThePreviousDepthsByTheMargin) {
  const cv::Mat before = Grey(1, 1.0), now = Grey(2, 1.0);
  const TemporalBoundsOptions o = Options16();
  TemporalBoundsStats st;
  const SearchBounds b = TemporalBounds({Plane(2000)}, before, now, kZMin, kZMax, kLevels, o,
                                        "cam", &st);
  EXPECT_EQ(st.tiles, 4 * 3);
  EXPECT_EQ(st.bounded, 12);
  EXPECT_EQ(st.changed, 0);
  const cv::Vec2f px = b.near_far_mm.at<cv::Vec2f>(20, 30);
  EXPECT_NEAR(px[0], 1.0 / (1.0 / 2000 + Margin(o.margin_levels)), 1e-2);
  EXPECT_NEAR(px[1], 1.0 / (1.0 / 2000 - Margin(o.margin_levels)), 1e-2);
  EXPECT_LT(px[0], 2000);
  EXPECT_GT(px[1], 2000);
  // The threshold is the noise's: 3x the median tile's mean |difference| (about
  // 2 sigma / sqrt(pi) = 1.13 greys for sigma 1 each) plus 2.
  EXPECT_NEAR(st.threshold_grey, 3 * 1.13 + 2, 0.5);
  // A few wrong matches in a tile (under 2 % of its depths) do not widen its range.
  RangeImage wild = Plane(2000);
  for (int k = 0; k < 4; ++k) wild.depth_mm.at<float>(20 + k, 30) = 4500;
  const SearchBounds w = TemporalBounds({wild}, before, now, kZMin, kZMax, kLevels, o, "cam");
  EXPECT_EQ(w.near_far_mm.at<cv::Vec2f>(20, 30), px);
}

TEST(TemporalBounds, ChangedTilesAndTilesWithoutDepthsAreSearchedWhole) {
  const cv::Mat before = Grey(1, 1.0);
  cv::Mat now = Grey(2, 1.0);
  now(cv::Rect(0, 0, 16, 16)) += 40.0;  // something moved into the first tile
  RangeImage prev = Plane(2000);
  prev.depth_mm(cv::Rect(48, 32, 16, 16)).setTo(0);  // nothing found in the last tile
  TemporalBoundsStats st;
  const SearchBounds b = TemporalBounds({prev}, before, now, kZMin, kZMax, kLevels,
                                        Options16(), "cam", &st);
  EXPECT_EQ(st.changed, 1);
  EXPECT_EQ(st.unknown, 1);
  EXPECT_EQ(st.bounded, 10);
  EXPECT_EQ(b.near_far_mm.at<cv::Vec2f>(5, 5), cv::Vec2f(kZMin, kZMax));
  EXPECT_EQ(b.near_far_mm.at<cv::Vec2f>(40, 60), cv::Vec2f(kZMin, kZMax));
  EXPECT_LT(b.near_far_mm.at<cv::Vec2f>(5, 20)[1], 2400);  // 2000 and 8 levels
  // A noisier camera is not judged changed by its noise alone.
  TemporalBoundsStats noisy;
  TemporalBounds({Plane(2000)}, Grey(3, 8.0), Grey(4, 8.0), kZMin, kZMax, kLevels,
                 Options16(), "cam", &noisy);
  EXPECT_EQ(noisy.bounded, 12);
}

TEST(TemporalBounds, ATileTakesItsNeighboursDepthsAndTheWindowsUnion) {
  // Depths 2000 in the left half, 3000 in the right half's 7x7 window image only.
  RangeImage left = Plane(2000), right = Plane(3000);
  left.depth_mm(cv::Rect(32, 0, 32, 48)).setTo(0);
  right.depth_mm(cv::Rect(0, 0, 32, 48)).setTo(0);
  TemporalBoundsOptions o = Options16();
  o.margin_levels = 1;
  const SearchBounds b =
      TemporalBounds({left, right}, Grey(1, 1), Grey(2, 1), kZMin, kZMax, kLevels, o, "cam");
  // Tile column 1 (x 16..31) borders column 2's 3000: both depths are in its range.
  const cv::Vec2f edge = b.near_far_mm.at<cv::Vec2f>(20, 20);
  EXPECT_LT(edge[0], 2000);
  EXPECT_GT(edge[1], 3000);
  // Column 0 sees only 2000.
  EXPECT_LT(b.near_far_mm.at<cv::Vec2f>(20, 5)[1], 2100);
}

TEST(TemporalBounds, IntersectionKeepsTheOuterWhereTheyDisagree) {
  SearchBounds outer{cv::Mat(2, 2, CV_32FC2, cv::Scalar(1000, 3000))};
  outer.near_far_mm.at<cv::Vec2f>(1, 1) = cv::Vec2f(0, 0);  // not searched
  SearchBounds inner{cv::Mat(2, 2, CV_32FC2, cv::Scalar(2000, 4000))};
  inner.near_far_mm.at<cv::Vec2f>(0, 1) = cv::Vec2f(3500, 4000);  // disagrees
  const SearchBounds b = IntersectBounds(outer, inner);
  EXPECT_EQ(b.near_far_mm.at<cv::Vec2f>(0, 0), cv::Vec2f(2000, 3000));
  EXPECT_EQ(b.near_far_mm.at<cv::Vec2f>(0, 1), cv::Vec2f(1000, 3000));
  EXPECT_EQ(b.near_far_mm.at<cv::Vec2f>(1, 1), cv::Vec2f(0, 0));
}

TEST(TemporalBounds, BadInputsAreNamed) {
  const cv::Mat g = Grey(1, 1);
  testing::ExpectInputError(
      [&] {
        TemporalBounds({Plane(2000)}, g, g(cv::Rect(0, 0, 32, 32)).clone(), kZMin, kZMax,
                       kLevels, {}, "job x");
      },
      {"job x", "one size"});
  RangeImage small = Plane(2000);
  small.depth_mm = cv::Mat(10, 10, CV_32FC1, cv::Scalar(0));
  testing::ExpectInputError(
      [&] { TemporalBounds({small}, g, g, kZMin, kZMax, kLevels, {}, "job x"); },
      {"job x", "previous instant's range image", "10x10"});
  TemporalBoundsOptions o;
  o.tile_px = 2;
  testing::ExpectInputError([&] { o.Check(); }, {"temporal.tile_px", "4..256"});
  o = {};
  o.change_factor = 0.5;
  testing::ExpectInputError([&] { o.Check(); }, {"temporal.change_factor"});
}

// The change rule alone: a tile changed when its mean difference exceeds factor x the
// median tile's plus the floor; a tile without a pixel of both greys counts as changed.
TEST(TemporalBounds, ChangedTilesFollowTheRuleAndNameBadGreys) {
  cv::Mat before(64, 96, CV_32FC1, cv::Scalar(100)), now = before.clone();
  // Noise of mean 1 grey everywhere (alternating +-1), a change of 10 greys in tile (1, 0).
  for (int y = 0; y < now.rows; ++y)
    for (int x = 0; x < now.cols; ++x) now.at<float>(y, x) += (x + y) % 2 ? 1.0f : -1.0f;
  now(cv::Rect(32, 0, 32, 32)) += 9.0;
  now(cv::Rect(64, 32, 32, 32)).setTo(NAN);
  double threshold = 0;
  const cv::Mat changed = ChangedTiles(before, now, 32, 3.0, 2.0, "test", &threshold);
  ASSERT_EQ(changed.size(), cv::Size(3, 2));
  EXPECT_DOUBLE_EQ(threshold, 3.0 * 1.0 + 2.0);
  EXPECT_EQ(changed.at<uint8_t>(0, 1), 1);
  EXPECT_EQ(changed.at<uint8_t>(1, 2), 1);  // no pixel with both greys
  EXPECT_EQ(cv::countNonZero(changed), 2);
  dome::testing::ExpectInputError(
      [&] { ChangedTiles(before, now(cv::Rect(0, 0, 10, 10)), 32, 3.0, 2.0, "camera x"); },
      {"camera x", "one float per pixel of one size", "96x64", "10x10"});
}

}  // namespace
}  // namespace dome::stereo
