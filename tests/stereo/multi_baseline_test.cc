#include "stereo/multi_baseline.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "stereo/stereo_test_util.h"
#include "testing/expect_error.h"

namespace dome::stereo {
namespace {

using testing::PlaneCamera;

StereoInput PlaneInput(double plane_mm, bool textured) {
  // 12 mm texels: about 1.2 px per texel at 2 m with f = 200 px.
  return testing::PlaneStereoInput(plane_mm, textured, {{120, 0}, {-120, 0}, {0, 90}, {0, -90}},
                                   /*texel_mm=*/12.0, /*seed=*/7);
}

// With the default warp (pre-warped neighbours, StereoOptions::prewarp_neighbours)
// unless `prewarp` says otherwise.
void ExpectPlaneRecovered(double plane_mm, double median_tolerance, double max_tolerance,
                          bool prewarp = StereoOptions().prewarp_neighbours) {
  StereoOptions opt;
  // 5: window sums added value by value; 9 = 8 + 1, 13 = 8 + 4 + 1, 17 = 16 + 1: sums of
  // sums (cost_kernel.cc WindowSum).
  opt.window_sizes_px = {5, 9, 13, 17};
  opt.num_threads = 2;
  opt.prewarp_neighbours = prewarp;
  const StereoResult r = ComputeDepth(PlaneInput(plane_mm, true), opt);
  // 200 px * 120 mm * (1/750 - 1/5000) = 27.2 px -> 29 levels.
  EXPECT_EQ(r.num_levels, 29);
  ASSERT_EQ(r.range_images.size(), 4u);
  for (const auto& ri : r.range_images) {
    // Interior pixels (every neighbour sees the window): exact to well under a level.
    std::vector<double> errors;
    int interior = 0;
    for (int y = 25; y < 95; ++y) {
      for (int x = 30; x < 130; ++x) {
        ++interior;
        const float d = ri.depth_mm.at<float>(y, x);
        if (d > 0) errors.push_back(std::abs(d - plane_mm) / plane_mm);
      }
    }
    ASSERT_GT(errors.size(), 0.95 * interior) << "window " << ri.window_px;
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
    EXPECT_LT(errors[errors.size() / 2], median_tolerance) << "window " << ri.window_px;
    const double max_err = *std::max_element(errors.begin(), errors.end());
    EXPECT_LT(max_err, max_tolerance) << "window " << ri.window_px;
    EXPECT_GT(ri.density, 0.5);
  }
}

// A plane exactly on a depth level: the recovered depth is exact (the parabola is
// symmetric there) up to the rendering's interpolation and 8-bit rounding: the
// median error is under 1/30 of a level (3% of the depth per level here).
TEST(MultiBaselineTest, RecoversFrontoParallelTexturedPlaneExactly) {
  ExpectPlaneRecovered(LevelDepthMm(7, 29, 750, 5000), 1e-3, 5e-3);
}

// Between levels (0.4 of a level, about 3% in depth per level here), the parabola gets
// to a fraction of a level: < 1% of the depth everywhere.
TEST(MultiBaselineTest, RecoversFrontoParallelTexturedPlaneBetweenLevels) {
  ExpectPlaneRecovered(2000.0, 0.006, 0.01);
}

// The same with the exact per-pixel warp (prewarp_neighbours false) and with the
// pre-warped neighbours: the same tolerances on and between levels.
TEST(MultiBaselineTest, RecoversPlaneWithEitherWarp) {
  for (bool prewarp : {false, true}) {
    SCOPED_TRACE(prewarp ? "pre-warped" : "exact warp");
    ExpectPlaneRecovered(LevelDepthMm(7, 29, 750, 5000), 1e-3, 5e-3, prewarp);
    ExpectPlaneRecovered(2000.0, 0.006, 0.01, prewarp);
  }
}

// StereoOptions::max_simd picks the cost kernel's path: with pre-warped neighbours
// every path this CPU runs gives the same depths and reliabilities, bit for bit.
TEST(MultiBaselineTest, EverySimdPathGivesTheSameDepths) {
  StereoOptions opt;
  opt.window_sizes_px = {5, 9};
  opt.num_threads = 2;
  const StereoInput in = PlaneInput(2000.0, true);
  opt.max_simd = 0;
  const StereoResult scalar = ComputeDepth(in, opt);
  EXPECT_GT(scalar.range_images[0].density, 0.5);
  for (int simd : {1, 2}) {
    opt.max_simd = simd;
    const StereoResult r = ComputeDepth(in, opt);
    for (size_t k = 0; k < r.range_images.size(); ++k) {
      const cv::Mat a = r.range_images[k].depth_mm, b = scalar.range_images[k].depth_mm;
      EXPECT_EQ(std::memcmp(a.data, b.data, a.total() * a.elemSize()), 0) << simd << " " << k;
      const cv::Mat ra = r.range_images[k].reliability, rb = scalar.range_images[k].reliability;
      EXPECT_EQ(std::memcmp(ra.data, rb.data, ra.total() * ra.elemSize()), 0) << simd << " " << k;
    }
  }
  opt.max_simd = 3;
  dome::testing::ExpectInputError([&] { opt.Check(); },
                                  {"max_simd", "must be 0 (scalar), 1 (AVX2) or 2 (AVX-512), got 3"});
}

TEST(MultiBaselineTest, MarksTexturelessSurfaceInvalid) {
  for (bool prewarp : {false, true}) {
    StereoOptions opt;
    opt.num_threads = 2;
    opt.prewarp_neighbours = prewarp;
    const StereoResult r = ComputeDepth(PlaneInput(2000.0, false), opt);
    ASSERT_EQ(r.range_images.size(), 1u);
    EXPECT_EQ(cv::countNonZero(r.range_images[0].depth_mm), 0) << prewarp;
    EXPECT_EQ(r.range_images[0].density, 0.0) << prewarp;
  }
}

// The grey mapping: 255 sqrt(g / 255) of the greys, after the percentile stretch when
// asked for (greys below its 1st percentile count as 0, above its 99th as 255).
// A 200x1 view of greys 20..219.
StereoView RampView() {
  StereoView view;
  view.camera = PlaneCamera("c", 0, 0, 200, 1);
  view.image = cv::Mat(1, 200, CV_8UC1);
  for (int x = 0; x < 200; ++x) view.image.at<uint8_t>(0, x) = uint8_t(x + 20);
  return view;
}

TEST(GreyImage, SquareRootsOfTheGreysAfterTheStretch) {
  const StereoView view = RampView();
  StereoOptions o;
  o.sqrt_greys = true;
  cv::Mat g = GreyImage(view, o, false, "view");
  for (int x : {0, 1, 50, 199}) {
    EXPECT_NEAR(g.at<float>(0, x), 255.0 * std::sqrt((x + 20) / 255.0), 1e-3) << x;
  }
  // 200 greys 20..219: the 1st percentile is 22, the 99th 218.
  o.normalize_contrast = true;
  g = GreyImage(view, o, false, "view");
  for (int x : {0, 2, 3, 100, 198, 199}) {
    const double stretched = std::clamp((x + 20 - 22) * 255.0 / (218 - 22), 0.0, 255.0);
    EXPECT_NEAR(g.at<float>(0, x), 255.0 * std::sqrt(stretched / 255.0), 1e-3) << x;
  }
  EXPECT_EQ(g.at<float>(0, 0), 0.0f);
  EXPECT_EQ(g.at<float>(0, 199), 255.0f);
}

// IdealGrey takes a view's own grey when it carries one (checked for its size), else
// makes it as GreyImage does with undistortion.
TEST(GreyImage, IdealGreyTakesTheViewsOwnOrMakesIt) {
  StereoView view = RampView();
  StereoOptions o;
  o.sqrt_greys = true;
  const cv::Mat made = IdealGrey(view, o, "view");
  EXPECT_EQ(cv::norm(made, GreyImage(view, o, true, "view"), cv::NORM_INF), 0.0);
  view.ideal_grey = cv::Mat(1, 200, CV_32FC1, cv::Scalar(7));
  EXPECT_EQ(IdealGrey(view, o, "view").at<float>(0, 13), 7.0f);
  view.ideal_grey = cv::Mat(1, 199, CV_32FC1, cv::Scalar(7));
  dome::testing::ExpectInputError([&] { IdealGrey(view, o, "neighbour 'c'"); },
                                  {"neighbour 'c': ideal grey", "camera's 200x1", "got 199x1"});
}

// The stretch's percentiles are the exact order statistics (what a full selection
// gives) on a float image of many distinct values, negative ones and both zeros
// included: the stretched image is the one computed from std::nth_element's values.
TEST(GreyImage, StretchUsesTheExactPercentiles) {
  StereoView view;
  view.camera = PlaneCamera("c", 0, 0, 300, 200);
  view.image = cv::Mat(200, 300, CV_32FC1);
  cv::RNG rng(7);
  rng.fill(view.image, cv::RNG::NORMAL, 60.0, 25.0);
  view.image.at<float>(0, 0) = -0.0f;
  view.image.at<float>(0, 1) = 0.0f;
  view.image(cv::Rect(0, 100, 300, 20)).setTo(42.0f);  // a run of equal values
  StereoOptions o;
  o.normalize_contrast = true;
  const cv::Mat g = GreyImage(view, o, false, "view");
  std::vector<float> v(view.image.begin<float>(), view.image.end<float>());
  const size_t i1 = v.size() / 100, i99 = v.size() * 99 / 100;
  std::nth_element(v.begin(), v.begin() + i1, v.end());
  const float lo = v[i1];
  std::nth_element(v.begin(), v.begin() + i99, v.end());
  const float hi = v[i99];
  const cv::Mat expected = (view.image - lo) * (255.0 / (hi - lo));
  EXPECT_EQ(cv::norm(g, expected, cv::NORM_INF), 0.0);
}

// sqrt_greys maps each image once, before matching: the depths are those of images
// mapped beforehand and matched as they are (which would differ if the mapping were
// applied twice or not at all); and the plane is still recovered.
TEST(MultiBaselineTest, SqrtGreysMatchesImagesMappedBeforehand) {
  StereoInput in = PlaneInput(2000.0, true);
  StereoOptions o;
  o.num_threads = 2;
  o.window_sizes_px = {9};
  o.normalize_contrast = true;
  o.sqrt_greys = true;
  const StereoResult mapped_here = ComputeDepth(in, o);
  for (StereoView* v : {&in.reference, &in.neighbours[0], &in.neighbours[1], &in.neighbours[2],
                        &in.neighbours[3]}) {
    v->image = GreyImage(*v, o, false, v->camera.id);
  }
  StereoOptions plain = o;
  plain.normalize_contrast = false;
  plain.sqrt_greys = false;
  const StereoResult mapped_before = ComputeDepth(in, plain);
  const RangeImage& a = mapped_here.range_images[0];
  const RangeImage& b = mapped_before.range_images[0];
  EXPECT_EQ(cv::norm(a.depth_mm, b.depth_mm, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.reliability, b.reliability, cv::NORM_INF), 0.0);
  EXPECT_GT(a.density, 0.5);
  // Matching the linear greys gives other values: the option is not ignored.
  StereoOptions linear = o;
  linear.sqrt_greys = false;
  EXPECT_GT(cv::norm(ComputeDepth(PlaneInput(2000.0, true), linear).range_images[0].reliability,
                     a.reliability, cv::NORM_INF),
            0.0);
  std::vector<double> errors;
  for (int y = 25; y < 95; ++y) {
    for (int x = 30; x < 130; ++x) {
      const float d = a.depth_mm.at<float>(y, x);
      if (d > 0) errors.push_back(std::abs(d - 2000.0) / 2000.0);
    }
  }
  ASSERT_GT(errors.size(), 0.95 * 70 * 100);
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.006);
}

TEST(MultiBaselineTest, LevelCountFromGeometry) {
  // Rectified pair: parallax f B (1/z_min - 1/z_max) = 200 * 300 * (1/750 - 1/5000)
  // = 68 px exactly -> 69 levels at 1 px, 35 at 2 px; a 0.7 px step: ceil(97.14) + 1.
  const auto ref = PlaneCamera("ref", 0, 0);
  const auto nb = PlaneCamera("nb", 300, 0);
  const double parallax = 200.0 * 300.0 * (1.0 / 750 - 1.0 / 5000);
  EXPECT_NEAR(parallax, 68.0, 1e-9);
  EXPECT_EQ(CountDepthLevels(ref, {nb}, 750, 5000, 1.0), 69);
  EXPECT_EQ(CountDepthLevels(ref, {nb}, 750, 5000, 2.0), 35);
  EXPECT_EQ(CountDepthLevels(ref, {nb}, 750, 5000, 0.7), int(std::ceil(parallax / 0.7)) + 1);
  // The widest baseline decides.
  const auto near_nb = PlaneCamera("near", 0, 100);
  EXPECT_EQ(CountDepthLevels(ref, {near_nb, nb}, 750, 5000, 1.0), 69);
  // Levels are uniform in inverse depth, level 0 at z_max.
  EXPECT_DOUBLE_EQ(LevelDepthMm(0, 69, 750, 5000), 5000);
  EXPECT_NEAR(LevelDepthMm(68, 69, 750, 5000), 750, 1e-9);
  EXPECT_NEAR(1.0 / LevelDepthMm(34, 69, 750, 5000), 0.5 * (1.0 / 750 + 1.0 / 5000), 1e-15);
}

TEST(MultiBaselineTest, BadInputsGiveClearErrors) {
  StereoOptions opt;
  opt.z_min_mm = 3000;
  opt.z_max_mm = 3000;
  dome::testing::ExpectInputError([&] { opt.Check(); }, {"z_max_mm", "greater than z_min_mm"});
  opt.z_max_mm = 1000;
  dome::testing::ExpectInputError([&] { ComputeDepth(PlaneInput(2000, true), opt); }, {"z_max_mm"});
  StereoOptions ok;
  StereoInput lonely = PlaneInput(2000, true);
  lonely.neighbours.clear();
  dome::testing::ExpectInputError([&] { ComputeDepth(lonely, ok); },
                                  {"cluster", "'ref'", "no neighbours"});
  StereoOptions even;
  even.window_sizes_px = {4};
  dome::testing::ExpectInputError([&] { even.Check(); }, {"window_sizes_px", "odd"});
  StereoInput wrong_size = PlaneInput(2000, true);
  wrong_size.neighbours[1].image = cv::Mat(10, 10, CV_8UC1, cv::Scalar(0));
  dome::testing::ExpectInputError([&] { ComputeDepth(wrong_size, ok); },
                                  {"neighbour 'n1'", "160x120"});
}

}  // namespace
}  // namespace dome::stereo
