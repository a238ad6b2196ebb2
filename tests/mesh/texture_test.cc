#include "mesh/texture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <optional>

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

// Two spheres, the small one in front of the big one for some cameras, meshed by
// marching cubes; each image is the exact ray cast of the spheres (world mm) with
// colours known at every surface point, optionally tinted per camera so that every
// camera's contribution shows in the weighted mean.
struct TwoSphereScene {
  std::vector<testing::Sphere> spheres = {{Eigen::Vector3d(0.2, -0.3, 0.1), 24.0},
                                          {Eigen::Vector3d(20.1, 22.3, 18.2), 10.0}};
  io::Mesh mesh;
  std::vector<TextureView> views;

  // Ground-truth BGR of the surface nearest to p: a gradient on the big sphere, a
  // flat green on the small one.
  cv::Vec3d TrueColour(const Eigen::Vector3d& p) const {
    const double d0 = std::abs((p - spheres[0].centre_mm).norm() - spheres[0].radius_mm);
    const double d1 = std::abs((p - spheres[1].centre_mm).norm() - spheres[1].radius_mm);
    if (d1 < d0) return {40, 220, 30};
    return {128 + 4 * p.x(), 128 + 4 * p.y(), 128 + 4 * p.z()};
  }

  explicit TwoSphereScene(bool tint) {
    fusion::VolumeGrid grid;
    grid.voxel_size_mm = 2.0;
    grid.nx = grid.ny = grid.nz = 40;
    grid.origin_mm = Eigen::Vector3d(-30, -30, -30);
    std::vector<float> distance, weight;
    for (int k = 0; k < grid.nz; ++k)
      for (int j = 0; j < grid.ny; ++j)
        for (int i = 0; i < grid.nx; ++i) {
          const Eigen::Vector3d p = grid.VoxelCentreMm(i, j, k);
          double d = std::numeric_limits<double>::infinity();
          for (const auto& s : spheres) d = std::min(d, (p - s.centre_mm).norm() - s.radius_mm);
          distance.push_back(float(d));
          weight.push_back(1.0f);
        }
    mesh = MarchingCubes(grid, distance, weight);
    // A ring at two heights with barrel and pincushion distortion, one camera aimed
    // off the scene (part of the mesh outside its image) and one beside the big
    // sphere looking past it (part of the mesh behind it).
    std::vector<geometry::TsaiCamera> cams;
    for (int c = 0; c < 8; ++c) {
      const double a = 2 * M_PI * c / 8 + 0.1;
      const Eigen::Vector3d centre(300 * std::cos(a), 300 * std::sin(a), c % 2 ? 120 : -80);
      cams.push_back(testing::LookAtCamera("c" + std::to_string(c), centre, Eigen::Vector3d::Zero(),
                                           160, 120, 20.0, c % 3 == 0 ? -0.05 : 0.05));
    }
    cams.push_back(testing::LookAtCamera("off", Eigen::Vector3d(0, -250, 60),
                                         Eigen::Vector3d(30, 0, 20), 160, 120, 12.0, 0.05));
    cams.push_back(testing::LookAtCamera("beside", Eigen::Vector3d(45, -10, 0),
                                         Eigen::Vector3d(45, 200, 30), 160, 120, 100.0, 0.02));
    for (size_t c = 0; c < cams.size(); ++c) {
      TextureView v;
      v.camera = cams[c];
      v.image = cv::Mat(v.camera.height_px, v.camera.width_px, CV_8UC3, cv::Scalar(0, 0, 0));
      const cv::Vec3d offset =
          tint ? cv::Vec3d(double(int(c * 37) % 61 - 30), double(int(c * 53) % 47 - 23),
                           double(c % 2 ? 25 : -25))
               : cv::Vec3d(0, 0, 0);
      const Eigen::Vector3d o = v.camera.CentreWorld();
      for (int y = 0; y < v.camera.height_px; ++y) {
        for (int x = 0; x < v.camera.width_px; ++x) {
          const Eigen::Vector3d d = v.camera.BackProject(Eigen::Vector2d(x, y));
          double best = std::numeric_limits<double>::infinity();
          for (const auto& s : spheres) {
            const Eigen::Vector3d oc = o - s.centre_mm;
            const double b = oc.dot(d),
                         disc = b * b - (oc.squaredNorm() - s.radius_mm * s.radius_mm);
            if (disc >= 0 && -b - std::sqrt(disc) > 0) best = std::min(best, -b - std::sqrt(disc));
          }
          if (!std::isfinite(best)) continue;
          const cv::Vec3d colour = TrueColour(o + best * d) + offset;
          for (int ch = 0; ch < 3; ++ch) {
            v.image.at<cv::Vec3b>(y, x)[ch] = cv::saturate_cast<uint8_t>(colour[ch]);
          }
        }
      }
      v.where = "frames/x/" + v.camera.id + ".png";
      views.push_back(std::move(v));
    }
  }
};

int MaxChannelDifference(const cv::Vec3b& a, const cv::Vec3b& b) {
  int d = 0;
  for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(int(a[c]) - int(b[c])));
  return d;
}

// The per-face culling and the fast projection against the exhaustive reference: with
// a different tint per camera, leaving out a camera that paints a texel, or adding one
// that does not, moves its colour by several levels.
TEST(Texture, CulledShadingEqualsTheExhaustiveReference) {
  const TwoSphereScene scene(/*tint=*/true);
  TextureOptions fast, reference;
  // A tolerance near the depth differences at grazing texels (~1 mm here) puts many
  // texels close to the cut, so a culling margin that is too tight shows.
  fast.depth_tolerance_mm = reference.depth_tolerance_mm = 1.0;
  fast.num_threads = reference.num_threads = 2;
  reference.exhaustive = true;
  const TexturedMesh a = BuildTextureAtlas(scene.mesh, scene.views, fast);
  const TexturedMesh b = BuildTextureAtlas(scene.mesh, scene.views, reference);
  ASSERT_EQ(a.atlas.size(), b.atlas.size());
  ASSERT_EQ(a.uv, b.uv);
  int texels_differing = 0, texels_grey = 0, max_diff = 0;
  for (int y = 0; y < a.atlas.rows; ++y) {
    for (int x = 0; x < a.atlas.cols; ++x) {
      const int d = MaxChannelDifference(a.atlas.at<cv::Vec3b>(y, x), b.atlas.at<cv::Vec3b>(y, x));
      texels_differing += d > 0;
      max_diff = std::max(max_diff, d);
      texels_grey += b.atlas.at<cv::Vec3b>(y, x) == cv::Vec3b(128, 128, 128);
    }
  }
  // Rounding of the distorted radius (Newton vs closed form) may tip a sum across a
  // half level, nothing more.
  EXPECT_LE(max_diff, 1);
  EXPECT_LE(texels_differing, int(a.atlas.total() / 1000));
  EXPECT_LT(texels_grey, int(a.atlas.total() / 10));  // most of the surface is seen

  io::Mesh va = scene.mesh, vb = scene.mesh;
  ColorVertices(&va, scene.views, fast);
  ColorVertices(&vb, scene.views, reference);
  int vertices_differing = 0;
  for (size_t i = 0; i < va.vertices.size(); ++i) {
    int d = 0;
    for (int c = 0; c < 3; ++c)
      d = std::max(d, std::abs(int(va.colors[i][c]) - int(vb.colors[i][c])));
    EXPECT_LE(d, 1) << i;
    vertices_differing += d > 0;
  }
  EXPECT_LE(vertices_differing, int(va.vertices.size() / 1000) + 1);
}

// The texture job's one preparation of the views gives exactly the two separate calls'
// colours and atlas; without the atlas it gives only the colours.
TEST(Texture, ColourAndAtlasEqualsTheSeparateCalls) {
  const TwoSphereScene scene(/*tint=*/true);
  TextureOptions o;
  o.num_threads = 2;
  io::Mesh separate = scene.mesh;
  ColorVertices(&separate, scene.views, o);
  const TexturedMesh atlas = BuildTextureAtlas(scene.mesh, scene.views, o);
  io::Mesh both = scene.mesh;
  const std::optional<TexturedMesh> combined = ColourAndAtlas(&both, scene.views, o, true);
  ASSERT_TRUE(combined.has_value());
  EXPECT_EQ(both.colors, separate.colors);
  EXPECT_EQ(combined->uv, atlas.uv);
  ASSERT_EQ(combined->atlas.size(), atlas.atlas.size());
  EXPECT_EQ(cv::norm(combined->atlas, atlas.atlas, cv::NORM_INF), 0.0);
  EXPECT_EQ(combined->mesh.faces, atlas.mesh.faces);
  io::Mesh colours_only = scene.mesh;
  EXPECT_FALSE(ColourAndAtlas(&colours_only, scene.views, o, false).has_value());
  EXPECT_EQ(colours_only.colors, separate.colors);
}

// Untinted images: every face's atlas texel at its centroid and every vertex colour
// equal the scene's true colour there, within the blur of bilinear sampling on a
// 4 level/mm gradient; cameras that see the small sphere in front of a point do not
// paint it (that would be 100+ levels off: a culling that keeps occluded cameras made
// the median 60).
TEST(Texture, ColoursMatchTheGroundTruthOfASyntheticScene) {
  const TwoSphereScene scene(/*tint=*/false);
  TextureOptions o;
  o.depth_tolerance_mm = 3.0;
  o.num_threads = 2;
  const TexturedMesh t = BuildTextureAtlas(scene.mesh, scene.views, o);
  std::vector<double> errors;
  for (size_t f = 0; f < scene.mesh.faces.size(); ++f) {
    Eigen::Vector2f uv = Eigen::Vector2f::Zero();
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (int m = 0; m < 3; ++m) {
      uv += t.uv[3 * f + m] / 3.0f;
      p += scene.mesh.vertices[scene.mesh.faces[f][m]].cast<double>() / 3.0;
    }
    const int x = int(uv.x() * t.atlas.cols), y = int((1.0f - uv.y()) * t.atlas.rows);
    const cv::Vec3b got = t.atlas.at<cv::Vec3b>(y, x);
    const cv::Vec3d truth = scene.TrueColour(p);
    double e = 0;
    for (int c = 0; c < 3; ++c)
      e = std::max(e, std::abs(got[c] - std::clamp(truth[c], 0.0, 255.0)));
    errors.push_back(e);
  }
  ASSERT_GT(errors.size(), 1000u);
  std::sort(errors.begin(), errors.end());
  // Measured here: median 0.7, 95th percentile 3, 99th 20 levels (texels next to the
  // silhouette blend in the black background).
  EXPECT_LE(errors[errors.size() / 2], 1.5);
  EXPECT_LE(errors[errors.size() * 95 / 100], 6.0);
  EXPECT_LE(errors[errors.size() * 99 / 100], 30.0);

  io::Mesh m = scene.mesh;
  ColorVertices(&m, scene.views, o);
  std::vector<double> vertex_errors;
  for (size_t i = 0; i < m.vertices.size(); ++i) {
    const cv::Vec3d truth = scene.TrueColour(m.vertices[i].cast<double>());
    const io::Color3u8 got = m.colors[i];  // RGB
    double e = 0;
    for (int c = 0; c < 3; ++c)
      e = std::max(e, std::abs(got[2 - c] - std::clamp(truth[c], 0.0, 255.0)));
    vertex_errors.push_back(e);
  }
  std::sort(vertex_errors.begin(), vertex_errors.end());
  EXPECT_LE(vertex_errors[vertex_errors.size() / 2], 1.5);         // measured 0.3
  EXPECT_LE(vertex_errors[vertex_errors.size() * 95 / 100], 8.0);  // measured 4
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
