#include "mesh/texture.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "fusion/fusion_test_util.h"
#include "io/image_io.h"
#include "mesh/marching_cubes.h"
#include "mesh/mesh_test_util.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::mesh {
namespace {

// One camera on +x sees the sphere's +x half in red; the -x half is unseen (grey).
TEST(Texture, VisibleVerticesTakeTheImageColourOccludedOnesDoNot) {
  const auto v = testing::SphereVolume(40, 12.0);
  io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  TextureView view;
  view.camera = testing::LookAtCamera("c0", Eigen::Vector3d(400, 0, 0), Eigen::Vector3d::Zero(),
                                      160, 120, 30.0, 0.0);
  view.image = cv::Mat(120, 160, CV_8UC3, cv::Scalar(0, 0, 255));  // BGR red
  TextureOptions o;
  o.depth_tolerance_mm = 4.0;  // the sphere is 48 mm deep; grazing pixels differ by ~2 mm
  ColorVertices(&m, {view}, o);
  ASSERT_EQ(m.colors.size(), m.vertices.size());
  int red = 0, grey = 0;
  for (size_t i = 0; i < m.vertices.size(); ++i) {
    if (m.vertices[i].x() > 8) {
      EXPECT_EQ(m.colors[i], io::Color3u8(255, 0, 0)) << i;
      ++red;
    } else if (m.vertices[i].x() < -5) {
      EXPECT_EQ(m.colors[i], io::Color3u8(128, 128, 128)) << i;
      ++grey;
    }
  }
  EXPECT_GT(red, 100);
  EXPECT_GT(grey, 100);
  // The atlas writes an OBJ, an MTL and a PNG that reads back.
  const TexturedMesh t = BuildTextureAtlas(m, {view}, o);
  EXPECT_EQ(t.uv.size(), 3 * m.faces.size());
  const dome::testing::TempDir tmp;
  const std::filesystem::path dir = tmp.path();
  WriteTexturedObj(dir / "mesh.obj", t);
  EXPECT_TRUE(std::filesystem::exists(dir / "mesh.mtl"));
  const cv::Mat atlas = io::ReadImage(dir / "mesh.png", io::ImageMode::kBgr8);
  EXPECT_EQ(atlas.size(), t.atlas.size());
}

TEST(Texture, ImageSizeMustMatchItsCamera) {
  const auto v = testing::SphereVolume(10, 3.0);
  io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  TextureView view;
  view.camera =
      testing::LookAtCamera("c0", Eigen::Vector3d(400, 0, 0), Eigen::Vector3d::Zero(), 160, 120);
  view.image = cv::Mat(100, 160, CV_8UC3);
  view.where = "frames/x/c0.png";
  testing::ExpectInputError([&] { ColorVertices(&m, {view}, {}); },
                            {"frames/x/c0.png", "160x100", "160x120"});
}

}  // namespace
}  // namespace dome::mesh
