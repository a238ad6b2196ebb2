#include "mesh/preview.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fusion/fusion_test_util.h"
#include "mesh/marching_cubes.h"
#include "mesh/mesh_test_util.h"
#include "testing/expect_error.h"

namespace dome::mesh {
namespace {

// The sphere mesh of SphereVolume(40, 12): radius 24 mm around c, from marching cubes
// (within ~0.05 mm of the sphere), seen from 300 mm by a camera with distortion.
struct SphereScene {
  io::Mesh mesh;
  geometry::TsaiCamera camera;
  std::vector<testing::Sphere> truth;
};

SphereScene SphereSetup() {
  SphereScene s;
  const auto v = testing::SphereVolume(40, 12.0);
  s.mesh = MarchingCubes(v.grid, v.distance, v.weight);
  s.camera = testing::LookAtCamera("c0", Eigen::Vector3d(300, 40, 60), Eigen::Vector3d::Zero(), 96,
                                   72, 20.0, 0.05);
  s.truth = {{Eigen::Vector3d(0.173, -0.291, 0.117), 24.0}};
  return s;
}

TEST(Preview, DepthMatchesTheAnalyticSphere) {
  const SphereScene s = SphereSetup();
  const cv::Mat depth = RenderDepth(s.mesh, s.camera);
  const cv::Mat truth = testing::RenderSpheres(s.camera, s.truth);
  int both = 0, disagree = 0;
  double worst = 0;
  for (int y = 0; y < depth.rows; ++y) {
    for (int x = 0; x < depth.cols; ++x) {
      const float a = depth.at<float>(y, x), b = truth.at<float>(y, x);
      if (a > 0 && b > 0) {
        ++both;
        // Away from the silhouette (the sphere's front is at ~284.5 mm, its rim at
        // ~307 mm) the mesh is within a fraction of a mm along the ray.
        if (b < 296) worst = std::max(worst, double(std::abs(a - b)));
      } else if ((a > 0) != (b > 0)) {
        ++disagree;
      }
    }
  }
  EXPECT_GT(both, 300);
  EXPECT_LT(worst, 0.3);
  // Hit/miss differs only on silhouette pixels: a few percent of the disc at most.
  EXPECT_LT(disagree, both / 20 + 5);
}

TEST(Preview, GreyShadingFollowsTheNormalAndColoursAreInterpolated) {
  SphereScene s = SphereSetup();
  PreviewOptions o;
  const cv::Mat grey = RenderPreview(s.mesh, s.camera, o);
  const cv::Mat truth = testing::RenderSpheres(s.camera, s.truth);
  ASSERT_EQ(grey.type(), CV_8UC3);
  // The pixel nearest the sphere centre faces the camera: close to full brightness;
  // misses are black.
  Eigen::Vector2d centre_px;
  ASSERT_TRUE(s.camera.Project(s.truth[0].centre_mm, &centre_px));
  const cv::Vec3b c =
      grey.at<cv::Vec3b>(int(std::lround(centre_px.y())), int(std::lround(centre_px.x())));
  EXPECT_GE(c[0], 245);
  EXPECT_EQ(c[0], c[1]);
  EXPECT_EQ(grey.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 0));
  // Uniform vertex colours come out unchanged (RGB 10, 200, 30 -> BGR).
  s.mesh.colors.assign(s.mesh.vertices.size(), io::Color3u8(10, 200, 30));
  const cv::Mat coloured = RenderPreview(s.mesh, s.camera, o);
  int hits = 0;
  for (int y = 0; y < coloured.rows; ++y) {
    for (int x = 0; x < coloured.cols; ++x) {
      if (truth.at<float>(y, x) > 0 && coloured.at<cv::Vec3b>(y, x) != cv::Vec3b(0, 0, 0)) {
        EXPECT_EQ(coloured.at<cv::Vec3b>(y, x), cv::Vec3b(30, 200, 10));
        ++hits;
      }
    }
  }
  EXPECT_GT(hits, 300);
}

TEST(Preview, BadInputIsRejected) {
  SphereScene s = SphereSetup();
  s.mesh.faces.push_back(Eigen::Vector3i(0, 1, int(s.mesh.vertices.size())));
  testing::ExpectInputError([&] { RenderPreview(s.mesh, s.camera); }, {"preview: mesh"});
  s = SphereSetup();
  s.camera.width_px = 0;
  testing::ExpectInputError([&] { RenderPreview(s.mesh, s.camera); }, {"preview: camera c0"});
}

}  // namespace
}  // namespace dome::mesh
