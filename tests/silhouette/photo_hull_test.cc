// Photo-consistency carving of the visual hull (silhouette/photo_hull.h) on the classic
// ghost of two objects seen by four cameras on two axes: each camera's silhouette holds
// both spheres, and the hull holds four blobs, the two spheres and two ghosts where the
// cameras' cones cross. A ghost shows one camera the red sphere's colour and another the
// blue one's; the spheres show each camera their own colour.
#include "silhouette/photo_hull.h"

#include <gtest/gtest.h>

#include <vector>

#include "core/error.h"
#include "fusion/fusion_test_util.h"
#include "fusion/hull_fusion.h"
#include "silhouette/hull.h"
#include "testing/expect_error.h"

namespace dome::silhouette {
namespace {

struct Scene {
  std::vector<geometry::TsaiCamera> cameras;
  std::vector<cv::Mat> images;  // BGR
  std::vector<cv::Mat> masks;
};

constexpr double kOffset = 300.0;  // the spheres' centres at (-d, -d) and (d, d), mm
constexpr double kRadius = 120.0;

// Cameras 3 m away on +x, -x, +y and -y, looking at the origin, without distortion (the
// lens is the hull's and Project's business, tested with them). The red sphere at
// (-d, -d, 0), the blue one at (d, d, 0) on a grey background.
// With `bead`, a third sphere of 12 mm at (0, 0, 60) in green: thinner than the
// opening's ball (PhotoHullOptions::open_radius_cells), and alone in every camera.
constexpr double kBeadRadius = 12.0;
const Eigen::Vector3d kBead(0, 0, 60);

Scene TwoSpheres(bool bead = false) {
  Scene s;
  std::vector<testing::Sphere> spheres = {{Eigen::Vector3d(-kOffset, -kOffset, 0), kRadius},
                                          {Eigen::Vector3d(kOffset, kOffset, 0), kRadius}};
  if (bead) spheres.push_back({kBead, kBeadRadius});
  const cv::Vec3b colour[3] = {cv::Vec3b(40, 40, 200), cv::Vec3b(200, 60, 40),
                               cv::Vec3b(40, 200, 40)};
  const Eigen::Vector3d at[4] = {{3000, 0, 0}, {-3000, 0, 0}, {0, 3000, 0}, {0, -3000, 0}};
  for (int c = 0; c < 4; ++c) {
    const geometry::TsaiCamera cam = testing::LookAtCamera(
        "c" + std::to_string(c), at[c], Eigen::Vector3d::Zero(), 240, 160, 40.0, 0.0);
    cv::Mat image(cam.height_px, cam.width_px, CV_8UC3, cv::Scalar(90, 90, 90));
    cv::Mat mask(cam.height_px, cam.width_px, CV_8UC1, cv::Scalar(0));
    const Eigen::Vector3d o = cam.CentreWorld();
    for (int y = 0; y < cam.height_px; ++y) {
      for (int x = 0; x < cam.width_px; ++x) {
        double t = 0;
        const int hit =
            testing::NearestSphere(o, cam.BackProject(Eigen::Vector2d(x, y)), spheres, &t);
        if (hit < 0) continue;
        image.at<cv::Vec3b>(y, x) = colour[hit];
        mask.at<uint8_t>(y, x) = 255;
      }
    }
    s.cameras.push_back(cam);
    s.images.push_back(image);
    s.masks.push_back(mask);
  }
  return s;
}

HullOptions AllFourViews() {
  HullOptions o;
  o.min_views = 4;
  o.carve_votes = 1;
  o.num_threads = 2;
  return o;
}

TEST(PhotoHull, CarvesTheGhostsOfTwoSpheresAndKeepsTheSpheres) {
  const Scene s = TwoSpheres();
  const VisualHull hull(s.cameras, s.masks, AllFourViews());
  const Eigen::Vector3d real[2] = {{-kOffset, -kOffset, 0}, {kOffset, kOffset, 0}};
  const Eigen::Vector3d ghost[2] = {{kOffset, -kOffset, 0}, {-kOffset, kOffset, 0}};
  // The silhouettes alone cannot tell them apart.
  for (const auto& p : real) ASSERT_TRUE(hull.Inside(p));
  for (const auto& p : ghost) ASSERT_TRUE(hull.Inside(p));

  PhotoHullOptions po;
  po.cell_mm = 20.0;
  po.num_threads = 2;
  po.open_radius_cells = 0;  // the colours alone (the opening: the test below)
  const Eigen::Vector3d lo(-600, -600, -200), hi(600, 600, 200);
  const PhotoHull photo(hull, s.cameras, s.images, lo, hi, po);
  EXPECT_GT(photo.stats().hull_cells, 0);
  EXPECT_EQ(photo.stats().opened_cells, 0);
  EXPECT_GE(photo.stats().sweeps, 2);  // a ghost is thicker than one cell
  // The ghosts are carved through to their centres; each sphere keeps its whole
  // volume: a point a few mm inside its surface is on the kept side.
  for (const auto& p : ghost) EXPECT_GT(photo.CarvedDistanceMm(p), 0.0) << p.transpose();
  for (const auto& c : real) {
    EXPECT_LT(photo.CarvedDistanceMm(c), 0.0) << c.transpose();
    for (const Eigen::Vector3d& dir :
         {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(-1, 0, 0), Eigen::Vector3d(0, 1, 0),
          Eigen::Vector3d(0, -1, 0), Eigen::Vector3d(0, 0, 1)}) {
      const Eigen::Vector3d p = c + (kRadius - 15.0) * dir;
      EXPECT_LT(photo.CarvedDistanceMm(p), 0.0) << p.transpose();
    }
  }
  // Nothing is carved when every camera sees one colour (grey spheres on grey: every
  // cell agrees), and then every distance is the kept side's.
  std::vector<cv::Mat> flat;
  for (const cv::Mat& im : s.images) flat.emplace_back(im.size(), CV_8UC3, cv::Scalar(90, 90, 90));
  const PhotoHull none(hull, s.cameras, flat, lo, hi, po);
  EXPECT_EQ(none.stats().carved_cells, 0);
  EXPECT_EQ(none.stats().sweeps, 1);
  for (const auto& p : ghost) EXPECT_DOUBLE_EQ(none.CarvedDistanceMm(p), -10.0);
}

// The opening carves what no silhouette needs and keeps a part thinner than its ball that
// the silhouettes show: every mask pixel's ray still meets a kept cell.
TEST(PhotoHull, TheOpeningKeepsWhatASilhouetteNeedsHoweverThin) {
  const Scene s = TwoSpheres(/*bead=*/true);
  const VisualHull hull(s.cameras, s.masks, AllFourViews());
  ASSERT_TRUE(hull.Inside(kBead));
  PhotoHullOptions po;
  po.cell_mm = 10.0;
  po.num_threads = 2;
  po.open_radius_cells = 3;  // a ball of 30 mm: the bead (24 mm across) does not hold it
  const Eigen::Vector3d lo(-600, -600, -200), hi(600, 600, 200);
  // Grey everywhere: no colour carves, so what is carved is the opening's.
  std::vector<cv::Mat> flat;
  for (const cv::Mat& im : s.images) flat.emplace_back(im.size(), CV_8UC3, cv::Scalar(90, 90, 90));
  for (const std::vector<cv::Mat>* images :
       std::vector<const std::vector<cv::Mat>*>{&flat, &s.images}) {
    const PhotoHull photo(hull, s.cameras, *images, lo, hi, po);
    const PhotoHullStats& st = photo.stats();
    // Thin parts no silhouette needs are carved (the hull's edges where the cameras' cones
    // meet: about 4 % of it), and the bead, eroded whole, is kept.
    EXPECT_GT(st.opened_cells, st.hull_cells / 50);
    EXPECT_GT(st.restored_cells, 0);
    EXPECT_LT(photo.CarvedDistanceMm(kBead), 0.0);
    for (const Eigen::Vector3d& c :
         {Eigen::Vector3d(-kOffset, -kOffset, 0), Eigen::Vector3d(kOffset, kOffset, 0)})
      EXPECT_LT(photo.CarvedDistanceMm(c), 0.0) << c.transpose();
    // Every camera's mask pixels (every other row and column): the ray meets a point in
    // the hull on the kept side.
    for (size_t c = 0; c < s.cameras.size(); ++c) {
      const geometry::TsaiCamera& cam = s.cameras[c];
      const Eigen::Vector3d o = cam.CentreWorld();
      int lost = 0, pixels = 0;
      for (int y = 0; y < cam.height_px; y += 2) {
        for (int x = 0; x < cam.width_px; x += 2) {
          if (!s.masks[c].at<uint8_t>(y, x)) continue;
          ++pixels;
          const Eigen::Vector3d d = cam.BackProject(Eigen::Vector2d(x, y));
          bool met = false;
          for (double t = 2000; t <= 4000 && !met; t += 2.5) {
            const Eigen::Vector3d p = o + t * d;
            met = hull.Inside(p) && photo.CarvedDistanceMm(p) < 0.0;
          }
          lost += !met;
        }
      }
      EXPECT_GT(pixels, 100);
      EXPECT_EQ(lost, 0) << "camera " << cam.id;
    }
  }
}

TEST(PhotoHull, FusionMakesTheCarvedGhostsFreeSpaceAndTheHullSurfaceStandsInOnlyForTheSpheres) {
  const Scene s = TwoSpheres();
  const VisualHull hull(s.cameras, s.masks, AllFourViews());
  PhotoHullOptions po;
  po.cell_mm = 20.0;
  po.num_threads = 2;
  const PhotoHull photo(hull, s.cameras, s.images, Eigen::Vector3d(-600, -600, -200),
                        Eigen::Vector3d(600, 600, 200), po);
  fusion::VolumeGrid grid;
  grid.origin_mm = Eigen::Vector3d(-600, -600, -20);
  grid.voxel_size_mm = 10.0;
  grid.nx = grid.ny = 120;
  grid.nz = 4;
  fusion::FusionOptions options;
  options.truncation_mm = options.front_clamp_mm = 10.0;
  fusion::HullFusionOptions ho;
  ho.fill_unseen = true;
  ho.num_threads = 2;
  auto fused = [&](const PhotoHull* p) {
    fusion::Slab slab;
    slab.k0 = 0;
    slab.k1 = grid.nz;
    slab.nx = grid.nx;
    slab.ny = grid.ny;
    slab.distance_mm.assign(size_t(grid.PlaneVoxels() * grid.nz), 0.0f);
    slab.weight.assign(slab.distance_mm.size(), 0.0f);
    fusion::ApplyHull(grid, hull, p, options, ho, &slab);
    return slab;
  };
  const fusion::Slab plain = fused(nullptr), carved = fused(&photo);
  // The voxel of the plane z = 5 mm nearest (x, y).
  auto at = [&](const fusion::Slab& slab, double x, double y) {
    const int i = int((x - grid.origin_mm.x()) / grid.voxel_size_mm);
    const int j = int((y - grid.origin_mm.y()) / grid.voxel_size_mm);
    return slab.distance_mm[size_t((2 * grid.ny + j) * grid.nx + i)];
  };
  // Without the photo hull a ghost's centre is inside (the hull's surface stands in);
  // with it, free space at the clamp. The spheres' centres are inside in both.
  EXPECT_LT(at(plain, kOffset, -kOffset), 0.0f);
  EXPECT_LT(at(plain, -kOffset, kOffset), 0.0f);
  EXPECT_FLOAT_EQ(at(carved, kOffset, -kOffset), 10.0f);
  EXPECT_FLOAT_EQ(at(carved, -kOffset, kOffset), 10.0f);
  EXPECT_FLOAT_EQ(at(carved, kOffset, kOffset), -10.0f);
  EXPECT_FLOAT_EQ(at(carved, -kOffset, -kOffset), -10.0f);
}

TEST(PhotoHull, NamesTheCameraWhoseImageDoesNotFitAndTheOptionOutOfRange) {
  const Scene s = TwoSpheres();
  const VisualHull hull(s.cameras, s.masks, AllFourViews());
  std::vector<cv::Mat> images = s.images;
  images[2] = cv::Mat(80, 120, CV_8UC3, cv::Scalar(0, 0, 0));
  const Eigen::Vector3d lo(-600, -600, -200), hi(600, 600, 200);
  dome::testing::ExpectInputError(
      [&] { PhotoHull(hull, s.cameras, images, lo, hi, PhotoHullOptions{}); },
      {"photo hull: camera c2", "expected a 240x160 colour image, got 120x80"});
  images = s.images;
  images.pop_back();
  dome::testing::ExpectInputError(
      [&] { PhotoHull(hull, s.cameras, images, lo, hi, PhotoHullOptions{}); },
      {"photo hull", "got 4 cameras and 3 images"});
  PhotoHullOptions po;
  po.colour_box_px = 4;
  dome::testing::ExpectInputError([&] { po.Check(); },
                                  {"PhotoHullOptions: colour_box_px", "expected an odd count"});
  po = {};
  po.open_radius_cells = -1;
  dome::testing::ExpectInputError([&] { po.Check(); },
                                  {"PhotoHullOptions: open_radius_cells", "expected >= 0"});
  po = {};
  po.max_colour_distance = 0;
  dome::testing::ExpectInputError([&] { po.Check(); },
                                  {"PhotoHullOptions: max_colour_distance", "positive"});
}

}  // namespace
}  // namespace dome::silhouette
