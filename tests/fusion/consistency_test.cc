#include "fusion/consistency.h"

#include <gtest/gtest.h>

#include <cstring>

#include "fusion/fusion_test_util.h"
#include "fusion/integrate.h"
#include "testing/expect_error.h"

namespace dome::fusion {
namespace {

using testing::ExpectInputError;

const std::vector<testing::Sphere> kSphere = {{Eigen::Vector3d(0, 0, 500), 200}};

// Eight cameras 45 degrees apart around the sphere, exact depth.
std::vector<RangeImage> SphereRing() { return testing::RingImages(kSphere, 8, 96, 72, {500}); }

int Valid(const cv::Mat& depth) { return cv::countNonZero(depth > 0); }

TEST(Consistency, KeepsTheSurfaceAndDropsAStrayPatch) {
  std::vector<RangeImage> images = SphereRing();
  // A gross mismatch: a 6x6 patch of camera 0 pushed 150 mm behind the sphere's front.
  const cv::Rect patch(45, 33, 6, 6);
  ASSERT_EQ(cv::countNonZero(images[0].depth_mm(patch) > 0), 36);
  images[0].depth_mm(patch) += 150.0f;
  ConsistencyOptions o;
  o.min_views = 1;
  // A pixel is ~18 mm on the sphere here: nearest-pixel look-ups on its slanted sides
  // differ by a few mm, the stray patch by 150.
  o.tolerance_mm = 10.0;
  const std::vector<cv::Mat> kept = KeepConsistentDepth(images, o);
  ASSERT_EQ(kept.size(), images.size());
  // The patch is gone: no other camera sees a surface there.
  EXPECT_EQ(cv::countNonZero(kept[0](patch) > 0), 0);
  for (size_t c = 0; c < images.size(); ++c) {
    // Kept samples are the input's, untouched; the 45-degree neighbours see most of each
    // view's sphere (all but a rim near the silhouette).
    cv::Mat diff;
    cv::absdiff(kept[c], images[c].depth_mm, diff);
    EXPECT_EQ(cv::countNonZero((kept[c] > 0) & (diff > 0)), 0) << c;
    const int before = Valid(images[c].depth_mm) - (c == 0 ? 36 : 0);
    EXPECT_GT(Valid(kept[c]), 0.7 * before) << c;
    EXPECT_LE(Valid(kept[c]), before) << c;
  }
  // Stricter: more agreeing cameras keep less, never more.
  o.min_views = 3;
  const std::vector<cv::Mat> strict = KeepConsistentDepth(images, o);
  for (size_t c = 0; c < images.size(); ++c) {
    EXPECT_EQ(cv::countNonZero((strict[c] > 0) & (kept[c] == 0)), 0);
    EXPECT_LT(Valid(strict[c]), Valid(kept[c]));
  }
}

TEST(Consistency, OtherWindowsOfTheSameCameraDoNotCount) {
  const std::vector<RangeImage> ring = SphereRing();
  // Camera 0 twice (two windows) and nobody else: nothing is confirmed.
  const std::vector<cv::Mat> kept = KeepConsistentDepth({ring[0], ring[0]}, ConsistencyOptions{});
  EXPECT_EQ(Valid(kept[0]), 0);
  EXPECT_EQ(Valid(kept[1]), 0);
  // With its neighbour it is.
  EXPECT_GT(Valid(KeepConsistentDepth({ring[0], ring[0], ring[1]}, ConsistencyOptions{})[0]), 0);
}

TEST(Consistency, BadOptionsGiveClearErrors) {
  const std::vector<RangeImage> ring = SphereRing();
  ConsistencyOptions o;
  o.min_views = 0;
  ExpectInputError([&] { KeepConsistentDepth(ring, o); }, {"min_consistent_views", "at least 1"});
  o = {};
  o.tolerance_mm = 0;
  ExpectInputError([&] { KeepConsistentDepth(ring, o); }, {"consistency_tolerance_mm"});
  FusionOptions f;
  f.min_consistent_views = -1;
  ExpectInputError([&] { f.Check(); }, {"min_consistent_views"});
  f = {};
  f.min_weight = -1;
  ExpectInputError([&] { f.Check(); }, {"min_weight"});
}

VolumeGrid SphereGrid() {
  VolumeGrid g;
  g.voxel_size_mm = 10;
  g.nx = g.ny = g.nz = 60;
  g.origin_mm = Eigen::Vector3d(-300, -300, 200);
  return g;
}

TEST(Consistency, FusionWithTheFilterCarvesNoTunnel) {
  std::vector<RangeImage> images = SphereRing();
  // Camera 0 sees a patch 80 mm too far: inside the sphere.
  const cv::Rect patch(42, 30, 12, 12);
  const Eigen::Vector2d centre(patch.x + 6, patch.y + 6);
  const float true_depth = images[0].depth_mm.at<float>(int(centre.y()), int(centre.x()));
  images[0].depth_mm(patch) += 80.0f;
  const VolumeGrid g = SphereGrid();
  // A voxel 40 mm inside the sphere on camera 0's ray through the patch.
  const Eigen::Vector3d p = images[0].camera.BackProjectAtDepth(centre, true_depth + 40.0);
  const Eigen::Vector3d f = (p - g.origin_mm) / g.voxel_size_mm;
  const size_t idx = (size_t(f.z()) * g.ny + size_t(f.y())) * g.nx + size_t(f.x());
  FusionOptions plain;
  plain.truncation_mm = plain.front_clamp_mm = 20;
  FusionOptions filtered = plain;
  filtered.min_consistent_views = 1;
  filtered.consistency_tolerance_mm = 5;
  const Slab a = Integrator(g, images, plain).IntegrateSlab(0, g.nz);
  const Slab b = Integrator(g, images, filtered).IntegrateSlab(0, g.nz);
  // Unfiltered, camera 0 calls the inside free space (a tunnel into the sphere)...
  ASSERT_GT(a.weight[idx], 0);
  EXPECT_GT(a.distance_mm[idx], 0.0f);
  // ...filtered, nobody does: unobserved or behind the surface.
  EXPECT_TRUE(b.weight[idx] == 0.0f || b.distance_mm[idx] < 0.0f)
      << b.weight[idx] << " " << b.distance_mm[idx];
  // Slabs of the filtered fusion are bit-identical to the whole.
  Integrator integrator(g, images, filtered);
  std::vector<float> d, w;
  for (int s = 0; s < 7; ++s) {
    const Slab part = integrator.IntegrateSlab(g.nz * s / 7, g.nz * (s + 1) / 7);
    d.insert(d.end(), part.distance_mm.begin(), part.distance_mm.end());
    w.insert(w.end(), part.weight.begin(), part.weight.end());
  }
  ASSERT_EQ(d.size(), b.distance_mm.size());
  EXPECT_EQ(std::memcmp(d.data(), b.distance_mm.data(), d.size() * 4), 0);
  EXPECT_EQ(std::memcmp(w.data(), b.weight.data(), w.size() * 4), 0);
}

TEST(Integrate, MinWeightLeavesThinlySeenVoxelsUnobserved) {
  const std::vector<RangeImage> images = SphereRing();
  const VolumeGrid g = SphereGrid();
  FusionOptions o;
  const Slab all = Integrator(g, images, o).IntegrateSlab(0, g.nz);
  o.min_weight = 3;
  const Slab some = Integrator(g, images, o).IntegrateSlab(0, g.nz);
  int dropped = 0, kept = 0;
  for (size_t v = 0; v < all.weight.size(); ++v) {
    if (all.weight[v] >= 3) {
      ++kept;
      EXPECT_EQ(some.weight[v], all.weight[v]);
      EXPECT_EQ(some.distance_mm[v], all.distance_mm[v]);
    } else {
      dropped += all.weight[v] > 0;
      EXPECT_EQ(some.weight[v], 0.0f);
      EXPECT_EQ(some.distance_mm[v], 0.0f);
    }
  }
  EXPECT_GT(kept, 0);
  EXPECT_GT(dropped, 0);
}

}  // namespace
}  // namespace dome::fusion
