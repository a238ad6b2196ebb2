// Coarse-to-fine stereo over tiles (stereo/coarse_to_fine.h) on a rendered textured
// plane: the depth of the full-range search, from far fewer levels per tile.
#include "stereo/coarse_to_fine.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "stereo/stereo_test_util.h"
#include "testing/expect_error.h"

namespace dome::stereo {
namespace {

using testing::PlaneCamera;

constexpr int kWidth = 320, kHeight = 240;
constexpr double kFocalPx = 400.0;

stereo::StereoInput PlaneInput(double plane_mm, bool textured) {
  // 6 mm texels: about 1.3 px per texel at 2 m with f = 400 px.
  return stereo::testing::PlaneStereoInput(plane_mm, textured, {{120, 0}, {0, 90}},
                                           /*texel_mm=*/6.0, /*seed=*/11, kWidth, kHeight,
                                           kFocalPx);
}

stereo::StereoOptions Options() {
  stereo::StereoOptions o;
  o.window_sizes_px = {9};
  o.num_threads = 2;
  o.normalize_contrast = true;
  return o;
}

// Relative depth errors over the interior (both neighbours see every window there).
std::vector<double> InteriorErrors(const cv::Mat& depth, double plane_mm, int* interior) {
  std::vector<double> errors;
  *interior = 0;
  for (int y = 40; y < kHeight - 40; ++y) {
    for (int x = 40; x < kWidth - 80; ++x) {
      ++*interior;
      const float d = depth.at<float>(y, x);
      if (d > 0) errors.push_back(std::abs(d - plane_mm) / plane_mm);
    }
  }
  return errors;
}

// Coarse pass at half resolution with 5 px windows, fine tiles of `tile_px`.
CoarseToFineOptions HalfScaleTiles(int tile_px) {
  CoarseToFineOptions c2f;
  c2f.coarse_factor = 2;
  c2f.coarse_window_px = 5;
  c2f.tile_px = tile_px;
  return c2f;
}

TEST(CoarseToFine, ReducedCameraProjectsToBlockCentres) {
  const auto cam = PlaneCamera("c", 10, -20, kWidth, kHeight, kFocalPx);
  for (int f : {2, 4}) {
    const auto r = ReducedCamera(cam, f);
    EXPECT_EQ(r.width_px, kWidth / f);
    EXPECT_EQ(r.height_px, kHeight / f);
    for (const Eigen::Vector3d& p :
         {Eigen::Vector3d(0, 0, 2000), Eigen::Vector3d(300, -200, 1500)}) {
      Eigen::Vector2d full, reduced;
      ASSERT_TRUE(cam.Project(p, &full));
      ASSERT_TRUE(r.Project(p, &reduced));
      EXPECT_NEAR(reduced.x(), (full.x() + 0.5) / f - 0.5, 1e-9);
      EXPECT_NEAR(reduced.y(), (full.y() + 0.5) / f - 0.5, 1e-9);
    }
  }
}

TEST(CoarseToFine, RecoversThePlaneAsTheFullSearchDoes) {
  const double plane_mm = 2000.0;
  const auto in = PlaneInput(plane_mm, true);
  const stereo::StereoResult full = stereo::ComputeDepth(in, Options());
  CoarseToFineOptions c2f;
  c2f.coarse_factor = 2;
  c2f.coarse_window_px = 5;
  c2f.tile_px = 48;
  CoarseToFineStats stats;
  const stereo::StereoResult fine = ComputeDepthCoarseToFine(in, Options(), c2f, &stats);
  ASSERT_EQ(fine.range_images.size(), 1u);
  EXPECT_EQ(fine.range_images[0].window_px, 9);
  // 400 px x 120 mm x (1/750 - 1/5000) = 54.4 px -> 56 levels for the full search; a
  // tile searches its coarse depths (good to a coarse level, 2 px) +- 2 coarse levels.
  EXPECT_EQ(full.num_levels, 56);
  EXPECT_LE(fine.num_levels, 14);
  int interior = 0;
  for (const auto* r : {&full, &fine}) {
    std::vector<double> errors = InteriorErrors(r->range_images[0].depth_mm, plane_mm, &interior);
    ASSERT_GT(errors.size(), 0.95 * interior);
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
    EXPECT_LT(errors[errors.size() / 2], 0.002);  // 4 mm at 2 m, 1/6 of a full-search level
    EXPECT_LT(*std::max_element(errors.begin(), errors.end()), 0.02);
  }
  EXPECT_NEAR(fine.range_images[0].density, full.range_images[0].density, 0.1);
  // 320 x 240 px in tiles of 48: 7 x 5, every one textured and seen.
  EXPECT_EQ(stats.tiles, 35);
  EXPECT_EQ(stats.tiles_matched, 35);
  EXPECT_LE(stats.mean_tile_levels, fine.num_levels);
  // Reduced twice: 200 px x 120 mm x (1/750 - 1/5000) = 27.2 px -> 29 levels.
  EXPECT_EQ(stats.coarse_levels, 29);
}

// Cameras with strong radial distortion (kappa1 0.02 / mm^2: 16 px at the corners,
// more than a tile's window margin): each whole image is undistorted once, so every
// tile keeps its pixels. (Undistorting each tile's crop lost a band at the tile edges
// whose sources lie outside the crop: on a Panoptic HD camera half the depths.) The
// interior depths and density are those of the full-range search, which undistorts
// the whole images itself.
TEST(CoarseToFine, DistortedImagesKeepTheFullSearchDensity) {
  const double plane_mm = 2000.0;
  StereoInput in = PlaneInput(plane_mm, true);
  const cv::Mat texture = stereo::testing::MakeTexture(1024, 11);
  std::vector<StereoView*> views = {&in.reference};
  for (auto& v : in.neighbours) views.push_back(&v);
  for (StereoView* v : views) {
    v->camera.kappa1_per_mm2 = 0.02;
    v->image = stereo::testing::RenderPlane(v->camera, plane_mm, texture, 6.0);
  }
  const Eigen::Vector2d corner(0, 0);
  ASSERT_GT((in.reference.camera.DistortPixel(corner) - corner).norm(), 12.0);
  const stereo::StereoResult full = stereo::ComputeDepth(in, Options());
  CoarseToFineOptions c2f = HalfScaleTiles(48);
  const stereo::StereoResult fine = ComputeDepthCoarseToFine(in, Options(), c2f);
  int interior = 0;
  for (const auto* r : {&full, &fine}) {
    std::vector<double> errors = InteriorErrors(r->range_images[0].depth_mm, plane_mm, &interior);
    ASSERT_GT(errors.size(), 0.95 * interior);
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
    EXPECT_LT(errors[errors.size() / 2], 0.002);
  }
  EXPECT_GT(full.range_images[0].density, 0.6);
  // Undistorting per tile gave 0.905 against the full search's 0.939 here; now 0.9396.
  EXPECT_NEAR(fine.range_images[0].density, full.range_images[0].density, 0.01);
}

TEST(CoarseToFine, ThreadCountDoesNotChangeTheResult) {
  const auto in = PlaneInput(2000.0, true);
  const CoarseToFineOptions c2f = HalfScaleTiles(40);
  stereo::StereoOptions one = Options(), three = Options();
  one.num_threads = 1;
  three.num_threads = 3;
  const auto a = ComputeDepthCoarseToFine(in, one, c2f).range_images[0];
  const auto b = ComputeDepthCoarseToFine(in, three, c2f).range_images[0];
  EXPECT_GT(a.density, 0.5);
  EXPECT_EQ(cv::norm(a.depth_mm, b.depth_mm, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.reliability, b.reliability, cv::NORM_INF), 0.0);
}

TEST(CoarseToFine, SpecklesAreRemovedFromTheWholeImageNotPerTile) {
  const auto in = PlaneInput(2000.0, true);
  const CoarseToFineOptions c2f = HalfScaleTiles(40);
  stereo::StereoOptions o = Options();
  const auto plain = ComputeDepthCoarseToFine(in, o, c2f).range_images[0];
  // Pieces of fewer than 2000 px go: more than a tile (1600 px) holds, so a filter run
  // per tile would leave nothing; the plane spans tiles and stays.
  o.speckle.min_area_px = 2000;
  o.speckle.max_step_mm = 20.0;
  const auto filtered = ComputeDepthCoarseToFine(in, o, c2f).range_images[0];
  stereo::RangeImage expected = plain;
  stereo::RemoveSpeckles(o.speckle, &expected.depth_mm, &expected.reliability);
  EXPECT_EQ(cv::norm(filtered.depth_mm, expected.depth_mm, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(filtered.reliability, expected.reliability, cv::NORM_INF), 0.0);
  EXPECT_GT(filtered.density, 0.5);
  EXPECT_DOUBLE_EQ(filtered.density,
                   double(cv::countNonZero(expected.depth_mm)) / (kWidth * kHeight));
}

// Square roots of the greys are taken once, on each whole image: the depths are those of
// images mapped beforehand (coarse_to_fine.h), not of tiles or coarse images mapped again.
TEST(CoarseToFine, SqrtGreysMapEachWholeImageOnce) {
  stereo::StereoInput in = PlaneInput(2000.0, true);
  const CoarseToFineOptions c2f = HalfScaleTiles(40);
  stereo::StereoOptions o = Options();
  o.sqrt_greys = true;
  const auto here = ComputeDepthCoarseToFine(in, o, c2f).range_images[0];
  in.reference.image = stereo::GreyImage(in.reference, o, false, "ref");
  for (auto& v : in.neighbours) v.image = stereo::GreyImage(v, o, false, v.camera.id);
  stereo::StereoOptions plain = o;
  plain.normalize_contrast = false;
  plain.sqrt_greys = false;
  const auto before = ComputeDepthCoarseToFine(in, plain, c2f).range_images[0];
  EXPECT_GT(here.density, 0.5);
  EXPECT_EQ(cv::norm(here.depth_mm, before.depth_mm, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(here.reliability, before.reliability, cv::NORM_INF), 0.0);
}

// Tiles the coarse pass leaves without enough depths are searched over the bounds of
// the searched tiles around them when fill_min_neighbours allows: on the plane every
// filled tile then gets its depth right, and the result holds what the unfilled one
// did, unchanged.
TEST(CoarseToFine, TilesWithoutCoarseDepthsAreFilledFromTheirNeighbours) {
  const double plane_mm = 2000.0;
  const auto in = PlaneInput(plane_mm, true);
  CoarseToFineOptions c2f = HalfScaleTiles(40);
  // A strict coarse pass and many coarse depths per tile: some tiles go unsearched.
  c2f.coarse_min_uniqueness = 3.0;
  c2f.min_coarse_depths = 500;
  CoarseToFineStats plain_stats, filled_stats;
  const auto plain = ComputeDepthCoarseToFine(in, Options(), c2f, &plain_stats).range_images[0];
  c2f.fill_min_neighbours = 1;
  const auto filled = ComputeDepthCoarseToFine(in, Options(), c2f, &filled_stats).range_images[0];
  EXPECT_EQ(plain_stats.tiles_filled, 0);
  ASSERT_GT(plain_stats.tiles_matched, 0);
  ASSERT_LT(plain_stats.tiles_matched, plain_stats.tiles - 8);
  EXPECT_GT(filled_stats.tiles_filled, 0);
  EXPECT_EQ(filled_stats.tiles_matched, plain_stats.tiles_matched + filled_stats.tiles_filled);
  EXPECT_GT(filled.density, plain.density + 0.05);
  int interior = 0;
  std::vector<double> errors = InteriorErrors(filled.depth_mm, plane_mm, &interior);
  ASSERT_GT(errors.size(), 0.95 * interior);
  EXPECT_LT(*std::max_element(errors.begin(), errors.end()), 0.02);
  // Searched tiles are searched as before.
  const cv::Mat had_depth = plain.depth_mm > 0;
  EXPECT_EQ(cv::norm(plain.depth_mm, filled.depth_mm, cv::NORM_INF, had_depth), 0.0);
  // Eight searched neighbours are more than any tile has when some are unsearched.
  c2f.fill_min_neighbours = 8;
  CoarseToFineStats all8;
  ComputeDepthCoarseToFine(in, Options(), c2f, &all8);
  EXPECT_LT(all8.tiles_filled, filled_stats.tiles_filled);
}

// A tile is filled only where the surface its searched neighbours found reaches it: with
// a fine pass that keeps no depth (a uniqueness no match passes), the same tiles go
// unsearched and none is filled.
TEST(CoarseToFine, TilesAreFilledOnlyWhereTheNeighboursSurfaceReaches) {
  const auto in = PlaneInput(2000.0, true);
  CoarseToFineOptions c2f = HalfScaleTiles(40);
  c2f.coarse_min_uniqueness = 3.0;
  c2f.min_coarse_depths = 500;
  c2f.fill_min_neighbours = 1;
  CoarseToFineStats found, none;
  ComputeDepthCoarseToFine(in, Options(), c2f, &found);
  stereo::StereoOptions strict = Options();
  strict.min_uniqueness = 100.0;
  const auto r = ComputeDepthCoarseToFine(in, strict, c2f, &none).range_images[0];
  EXPECT_EQ(cv::countNonZero(r.depth_mm), 0);
  EXPECT_GT(found.tiles_filled, 0);
  EXPECT_EQ(none.tiles_filled, 0);
  EXPECT_EQ(none.tiles_matched, found.tiles_matched - found.tiles_filled);
}

// A clip box holding only part of the plane: coarse depths whose points fall outside it
// do not seed tiles, so tiles that see only what lies outside the box (a table, the
// walls beyond the scene) are not searched; the part inside keeps its depths.
TEST(CoarseToFine, CoarseDepthsOutsideTheClipBoxSeedNoTile) {
  const double plane_mm = 2000.0;
  const auto in = PlaneInput(plane_mm, true);
  const auto& ref = in.reference.camera;
  CoarseToFineOptions c2f = HalfScaleTiles(40);
  CoarseToFineStats open_stats, clip_stats;
  const auto open = ComputeDepthCoarseToFine(in, Options(), c2f, &open_stats).range_images[0];
  // The box: the plane's points left of the reference camera's centre (world x below
  // the centre's), the plane's depth +-100 mm.
  const Eigen::Vector3d centre =
      ref.BackProjectAtDepth(Eigen::Vector2d(ref.width_px / 2.0, ref.height_px / 2.0), plane_mm);
  const Eigen::Vector3d corner = ref.BackProjectAtDepth(Eigen::Vector2d(0, 0), plane_mm);
  const double reach = 2 * (centre - corner).norm();
  c2f.clip = true;
  c2f.clip_pad_mm = 10;
  c2f.clip_min_mm = centre - Eigen::Vector3d(reach, reach, 100);
  c2f.clip_max_mm = centre + Eigen::Vector3d(0, reach, 100);
  const auto clip = ComputeDepthCoarseToFine(in, Options(), c2f, &clip_stats).range_images[0];
  EXPECT_LT(clip_stats.tiles_matched, open_stats.tiles_matched - 10);
  // A tile straddling the box's edge is searched whole: depths at most a tile and a
  // window (40 + 9 px, 245 mm at 2 m with f = 400 px) beyond it; none further out.
  int inside = 0, inside_with = 0;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const double wx = ref.BackProjectAtDepth(Eigen::Vector2d(x, y), plane_mm).x() - centre.x();
      const float d = clip.depth_mm.at<float>(y, x);
      if (wx > 49 * plane_mm / kFocalPx) {
        EXPECT_EQ(d, 0.0f) << x << " " << y;
      }
      if (wx < -40 && open.depth_mm.at<float>(y, x) > 0) {
        ++inside;
        inside_with += d > 0;
      }
    }
  }
  ASSERT_GT(inside, 5000);
  EXPECT_GT(inside_with, 0.97 * inside);
}

// The depths of a box a camera sees part of (ClipDepthRangeToVisibleBox): the samples
// in the image, widened by half a sample's diagonal; asked again, the same range (kept
// per camera and box); the same camera moved sideways sees more of the box, nearer (the
// pose is part of what is kept); a box behind it is named.
TEST(CoarseToFine, VisibleBoxDepthsFollowTheCameraAndAreKeptPerCameraAndBox) {
  geometry::TsaiCamera cam = PlaneCamera("c", 0, 0, kWidth, kHeight, kFocalPx);
  // The image's right edge (x = 319.5 px) is x = z 160 / 400 mm at depth z. The box's
  // samples are 2000 / 24 mm apart in depth: its near side, x = 1010 mm, first comes into
  // view at sample 19 (z = 2583 mm; at sample 18, 2500 mm, it is at 321.1 px).
  const Eigen::Vector3d lo(1010, -100, 1000), hi(1910, 100, 3000);
  auto clip = [&](const geometry::TsaiCamera& c) {
    StereoOptions o = Options();
    o.z_min_mm = 100;
    o.z_max_mm = 10000;
    ClipDepthRangeToVisibleBox(lo, hi, 0.0, c, "box", &o);
    return std::make_pair(o.z_min_mm, o.z_max_mm);
  };
  const double slack = 0.5 * (hi - lo).norm() / 24;
  const auto first = clip(cam);
  EXPECT_NEAR(first.first, 1000 + 19 * 2000.0 / 24 - slack, 1e-6);
  EXPECT_NEAR(first.second, 3000 + slack, 1e-6);
  EXPECT_EQ(clip(cam), first);
  // 300 mm to the right: x = 710 mm comes into view at sample 10 (z = 1833 mm).
  cam.translation_mm.x() -= 300;
  const auto moved = clip(cam);
  EXPECT_NEAR(moved.first, 1000 + 10 * 2000.0 / 24 - slack, 1e-6);
  EXPECT_NEAR(moved.second, 3000 + slack, 1e-6);
  StereoOptions o = Options();
  o.z_min_mm = 100;
  o.z_max_mm = 10000;
  dome::testing::ExpectInputError(
      [&] { ClipDepthRangeToVisibleBox(-hi, -lo, 0.0, cam, "box", &o); },
      {"box", "camera 'c' sees no depth of the clip box"});
}

// Bounds that let every tile search (the previous instant's depths over most of the
// image) run as one kernel pass over the whole images. With every pixel bounded by the
// whole range that is the plain search, bit for bit; with a band of depths around the
// plane, the depths inside it are the plain search's, bit for bit, and the pixels left
// out get none.
TEST(CoarseToFine, DenseBoundsSearchInOnePassAsThePlainSearchDoes) {
  const stereo::StereoInput in = PlaneInput(2000.0, true);
  stereo::StereoOptions o = Options();
  o.z_min_mm = 1000;
  o.z_max_mm = 4000;
  const stereo::StereoResult plain = stereo::ComputeDepth(in, o);
  stereo::SearchBounds whole{cv::Mat(kHeight, kWidth, CV_32FC2, cv::Scalar(1000, 4000))};
  CoarseToFineStats st;
  const stereo::StereoResult a = ComputeDepthBounded(in, o, whole, &st);
  EXPECT_EQ(st.tiles_matched, st.tiles);
  const cv::Mat& pd = plain.range_images[0].depth_mm;
  ASSERT_GT(cv::countNonZero(pd), kWidth * kHeight / 2);
  EXPECT_EQ(cv::countNonZero(a.range_images[0].depth_mm != pd), 0);
  EXPECT_EQ(cv::countNonZero(a.range_images[0].reliability != plain.range_images[0].reliability),
            0);
  // 1900..2100 mm, and a block of tiles not searched at all.
  stereo::SearchBounds band{cv::Mat(kHeight, kWidth, CV_32FC2, cv::Scalar(1900, 2100))};
  band.near_far_mm(cv::Rect(64, 64, 64, 64)).setTo(cv::Scalar(0, 0));
  const stereo::StereoResult b = ComputeDepthBounded(in, o, band, &st);
  EXPECT_EQ(st.tiles_matched, st.tiles - 4);
  EXPECT_LT(st.mean_tile_levels, 0.25 * plain.num_levels);
  const cv::Mat& bd = b.range_images[0].depth_mm;
  int same = 0, plain_inside = 0;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const float d = bd.at<float>(y, x), p = pd.at<float>(y, x);
      if (!band.Searched(x, y)) {
        EXPECT_EQ(d, 0.0f) << "(" << x << ", " << y << ")";
        continue;
      }
      if (p > 1900.0f && p < 2100.0f) {
        ++plain_inside;
        same += d == p;
      }
    }
  }
  ASSERT_GT(plain_inside, kWidth * kHeight / 2);
  // A pixel can differ only where its second-best cost lay outside the band (then its
  // uniqueness grows), or where a speckle changed: none here.
  EXPECT_EQ(same, plain_inside);
}

// Tile depths of another grid are named, with the count the camera needs.
TEST(CoarseToFine, TileDepthsOfTheWrongGridAreNamed) {
  stereo::TileDepths tiles;
  tiles.near_mm.assign(3, 1000.0f);
  tiles.far_mm.assign(3, 4000.0f);
  // 320x240 in 32 px tiles: 10 x 8.
  dome::testing::ExpectInputError(
      [&] { stereo::ComputeDepth(PlaneInput(2000.0, true), Options(), &tiles); },
      {"tile depths", "expected 80 tiles of 32 px", "got 3 and 3"});
}

TEST(CoarseToFine, TexturelessImagesGiveNoDepth) {
  const stereo::StereoResult r =
      ComputeDepthCoarseToFine(PlaneInput(2000.0, false), Options(), CoarseToFineOptions{});
  EXPECT_EQ(cv::countNonZero(r.range_images[0].depth_mm), 0);
  EXPECT_EQ(r.range_images[0].density, 0.0);
}

TEST(CoarseToFine, BadOptionsAreNamed) {
  const auto in = PlaneInput(2000.0, true);
  CoarseToFineOptions c2f;
  c2f.coarse_factor = 1;
  dome::testing::ExpectInputError([&] { ComputeDepthCoarseToFine(in, Options(), c2f); },
                                  {"coarse_to_fine.coarse_factor"});
  c2f = {};
  c2f.coarse_window_px = 4;
  dome::testing::ExpectInputError([&] { ComputeDepthCoarseToFine(in, Options(), c2f); },
                                  {"coarse_to_fine.coarse_window_px"});
  c2f = {};
  c2f.margin_levels = 0;
  dome::testing::ExpectInputError([&] { ComputeDepthCoarseToFine(in, Options(), c2f); },
                                  {"coarse_to_fine.margin_levels"});
  c2f = {};
  c2f.trim_fraction = 0.5;
  dome::testing::ExpectInputError([&] { ComputeDepthCoarseToFine(in, Options(), c2f); },
                                  {"coarse_to_fine.trim_fraction"});
  c2f = {};
  c2f.min_coarse_depths = 0;
  dome::testing::ExpectInputError([&] { ComputeDepthCoarseToFine(in, Options(), c2f); },
                                  {"coarse_to_fine.min_coarse_depths"});
  c2f = {};
  c2f.fill_min_neighbours = 9;
  dome::testing::ExpectInputError([&] { ComputeDepthCoarseToFine(in, Options(), c2f); },
                                  {"coarse_to_fine.fill_min_neighbours", "0..8"});
}

}  // namespace
}  // namespace dome::stereo
