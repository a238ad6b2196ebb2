// silhouette/render.h against values worked out by hand: a pinhole camera looking down
// +z with 100 px per unit of x / z, a cube whose front face projects onto whole pixels.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "silhouette/background.h"
#include "silhouette/render.h"
#include "testing/expect_error.h"

namespace dome::silhouette {
namespace {

// 64 x 48 pixels, focal 1 mm over 0.01 mm pixels: 100 px per unit of x / z; the
// principal point at pixel (32, 24); world = camera frame (mm).
geometry::TsaiCamera TestCamera() {
  geometry::TsaiCamera c;
  c.id = "c";
  c.width_px = 64;
  c.height_px = 48;
  c.focal_mm = 1.0;
  c.cx_px = 32.0;
  c.cy_px = 24.0;
  return c;
}

// An axis-aligned cube, x and y in [-h, h], z in [z0, z0 + 2h], outward-facing triangles,
// vertices offset by `shift` (mm).
void AddCube(io::Mesh* mesh, double h, double z0, const Eigen::Vector3f& shift = {0, 0, 0}) {
  const int base = int(mesh->vertices.size());
  for (int k = 0; k < 8; ++k)
    mesh->vertices.push_back(Eigen::Vector3f(float(k & 1 ? h : -h), float(k & 2 ? h : -h),
                                             float(z0 + (k & 4 ? 2 * h : 0))) +
                             shift);
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    mesh->faces.emplace_back(base + q[0], base + q[1], base + q[2]);
    mesh->faces.emplace_back(base + q[0], base + q[2], base + q[3]);
  }
}

TEST(RenderMesh, CubeFrontFaceCoversExactlyItsPixels) {
  // Front face at z = 1000, half-edge 105 mm: 10.5 px either side of the principal
  // point, so it covers the pixel centres 22..42 in x and 14..34 in y: 21 x 21 pixels.
  io::Mesh cube;
  AddCube(&cube, 105.0, 1000.0);
  const MeshRendering r = RenderMesh(TestCamera(), cube);
  const cv::Mat mask = RenderedMask(r);
  EXPECT_EQ(cv::countNonZero(mask), 21 * 21);
  EXPECT_EQ(cv::countNonZero(mask(cv::Rect(22, 14, 21, 21))), 21 * 21);
  for (int y = 14; y <= 34; ++y)
    for (int x = 22; x <= 42; ++x) {
      EXPECT_NEAR(r.depth.at<float>(y, x), 1000.0f, 1e-3f) << x << "," << y;
      EXPECT_LT(r.face.at<int>(y, x), 2);  // the front quad's two triangles
    }
  EXPECT_EQ(r.face.at<int>(0, 0), -1);
  EXPECT_TRUE(std::isinf(r.depth.at<float>(0, 0)));
  // Against a mask of the same square shifted by 3 px: 18 x 21 shared of 24 x 21.
  cv::Mat other = cv::Mat::zeros(48, 64, CV_8UC1);
  other(cv::Rect(25, 14, 21, 21)).setTo(255);
  EXPECT_DOUBLE_EQ(MaskIoU(mask, other), 18.0 / 24.0);
}

TEST(RenderMesh, NearerSurfaceWinsAndBehindTheCameraIsLeftOut) {
  io::Mesh mesh;
  AddCube(&mesh, 105.0, 1000.0);
  // A smaller cube in front: at z = 500, half-edge 25 mm = 5 px: pixel centres 27..37.
  AddCube(&mesh, 25.0, 500.0);
  // A cube behind the camera (z < 0) renders nothing.
  AddCube(&mesh, 105.0, -2000.0);
  const MeshRendering r = RenderMesh(TestCamera(), mesh);
  EXPECT_EQ(cv::countNonZero(RenderedMask(r)), 21 * 21);
  EXPECT_NEAR(r.depth.at<float>(24, 32), 500.0f, 1e-3f);
  EXPECT_GE(r.face.at<int>(24, 32), 12);
  EXPECT_NEAR(r.depth.at<float>(24, 26), 1000.0f, 1e-3f);
  EXPECT_NEAR(r.depth.at<float>(24, 27), 500.0f, 1e-3f);
}

TEST(RenderMesh, WeightsArePerspectiveCorrect) {
  // One triangle slanted in depth: corners at z 1000, 2000, 1000.
  io::Mesh mesh;
  mesh.vertices = {{-200, -150, 1000}, {400, -300, 2000}, {-200, 150, 1000}};
  mesh.faces = {{0, 1, 2}};
  const geometry::TsaiCamera camera = TestCamera();
  const MeshRendering r = RenderMesh(camera, mesh);
  int checked = 0;
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 64; ++x) {
      if (r.face.at<int>(y, x) != 0) continue;
      const cv::Vec3f w = r.weights.at<cv::Vec3f>(y, x);
      EXPECT_NEAR(w[0] + w[1] + w[2], 1.0f, 1e-5f);
      // The 3D point of the weights lies on the pixel's ray at the rendered depth.
      Eigen::Vector3d p = Eigen::Vector3d::Zero();
      for (int k = 0; k < 3; ++k) p += double(w[k]) * mesh.vertices[k].cast<double>();
      EXPECT_NEAR(p.z(), r.depth.at<float>(y, x), 1e-2);
      EXPECT_NEAR(100.0 * p.x() / p.z() + 32.0, x, 1e-4);
      EXPECT_NEAR(100.0 * p.y() / p.z() + 24.0, y, 1e-4);
      ++checked;
    }
  EXPECT_GT(checked, 200);
}

TEST(RenderMesh, LensDistortionMovesTheCornersAsTheCameraProjects) {
  geometry::TsaiCamera camera = TestCamera();
  camera.kappa1_per_mm2 = 10.0;  // barrel: the corners pulled towards the centre
  io::Mesh cube;
  AddCube(&cube, 105.0, 1000.0);
  Eigen::Vector2d corner;
  ASSERT_TRUE(camera.Project(Eigen::Vector3d(105, 105, 1000), &corner));
  // Edges are straight between the projected corners: the front face covers the pixel
  // centres within `a` of the principal point in x and y.
  const double a = corner.x() - 32.0;
  ASSERT_NEAR(corner.y() - 24.0, a, 1e-9);
  ASSERT_GT(a, 8.0);
  ASSERT_LT(a, 10.0);
  const int side = 2 * int(std::floor(a)) + 1;
  const cv::Mat mask = RenderedMask(RenderMesh(camera, cube));
  EXPECT_EQ(cv::countNonZero(mask), side * side);
  const int lo = 32 - int(std::floor(a));
  EXPECT_EQ(cv::countNonZero(mask(cv::Rect(lo, lo - 8, side, side))), side * side);
}

TEST(Shade, VertexColoursAtlasAndPsnrAreExact) {
  io::Mesh cube;
  AddCube(&cube, 105.0, 1000.0);
  cube.colors.assign(cube.vertices.size(), io::Color3u8(200, 100, 50));  // RGB
  const MeshRendering r = RenderMesh(TestCamera(), cube);
  const cv::Mat vc = ShadeVertexColours(r, cube);
  EXPECT_EQ(vc.at<cv::Vec3b>(24, 32), cv::Vec3b(50, 100, 200));  // BGR
  EXPECT_EQ(vc.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 0));
  // An atlas of four texels; every corner of every face at the centre of the top-right
  // one (u = 0.75, v = 0.75 with v up).
  cv::Mat atlas(2, 2, CV_8UC3, cv::Scalar(1, 2, 3));
  atlas.at<cv::Vec3b>(0, 1) = cv::Vec3b(10, 20, 30);
  const std::vector<Eigen::Vector2f> uv(3 * cube.faces.size(), Eigen::Vector2f(0.75f, 0.75f));
  const cv::Mat at = ShadeAtlas(r, uv, atlas);
  EXPECT_EQ(at.at<cv::Vec3b>(20, 30), cv::Vec3b(10, 20, 30));
  // PSNR: a difference of 5 grey levels in every channel inside the mask, and a large
  // one outside it that must not count: 10 log10(255^2 / 25).
  cv::Mat other = vc.clone();
  const cv::Mat mask = RenderedMask(r);
  other.setTo(cv::Scalar(55, 105, 205), mask);
  other.setTo(cv::Scalar(255, 255, 255), mask == 0);
  EXPECT_NEAR(MaskedPsnr(vc, other, mask), 10.0 * std::log10(255.0 * 255.0 / 25.0), 1e-9);
  EXPECT_TRUE(std::isinf(MaskedPsnr(vc, vc, mask)));
  EXPECT_TRUE(std::isnan(MaskedPsnr(vc, other, cv::Mat::zeros(48, 64, CV_8UC1))));
  dome::testing::ExpectInputError([&] { MaskedPsnr(vc, other, cv::Mat::zeros(4, 4, CV_8UC1)); },
                                  {"MaskedPsnr: mask", "the images' size"});
  io::Mesh grey = cube;
  grey.colors.clear();
  dome::testing::ExpectInputError([&] { ShadeVertexColours(r, grey); },
                                  {"ShadeVertexColours", "no per-vertex colours"});
}

TEST(MeshComponents, CountsPiecesSharingVertices) {
  io::Mesh mesh;
  EXPECT_EQ(MeshComponents(mesh), 0);
  AddCube(&mesh, 10.0, 100.0);
  EXPECT_EQ(MeshComponents(mesh), 1);
  AddCube(&mesh, 10.0, 100.0, {50, 0, 0});
  AddCube(&mesh, 10.0, 100.0, {-50, 0, 0});
  mesh.vertices.emplace_back(0, 0, 0);  // in no triangle: not a component
  EXPECT_EQ(MeshComponents(mesh), 3);
  // A triangle joining the first two cubes by their vertices.
  mesh.faces.emplace_back(0, 8, 9);
  EXPECT_EQ(MeshComponents(mesh), 2);
}

}  // namespace
}  // namespace dome::silhouette
