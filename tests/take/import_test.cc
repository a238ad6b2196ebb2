// Importers on the real shared data: a wrong pose direction or unit would put the
// reference geometry behind the cameras, off the images or off the object.
#include "take/import.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/json.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "io/ply.h"
#include "take/validate.h"
#include "take_fixture.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::take {
namespace {

namespace fs = std::filesystem;
using dome::testing::ExpectInputError;

const fs::path kShared = DOME_SHARED_DIR;

double Correlation(const std::vector<double>& a, const std::vector<double>& b) {
  const size_t n = a.size();
  if (n < 2) return 0.0;
  double ma = 0, mb = 0;
  for (size_t i = 0; i < n; ++i) ma += a[i], mb += b[i];
  ma /= n;
  mb /= n;
  double sab = 0, saa = 0, sbb = 0;
  for (size_t i = 0; i < n; ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return sab / std::sqrt(saa * sbb + 1e-30);
}

class HalconImportTest : public ::testing::TestWithParam<std::string> {};

TEST_P(HalconImportTest, ReferenceCloudLandsOnTheObjectInEveryCamera) {
  const fs::path scene = kShared / "data/robovision" / GetParam();
  if (!fs::exists(scene)) GTEST_SKIP() << "no shared data at " << scene;
  const dome::testing::TempDir tmp;
  const fs::path out = tmp.path();
  const Take take = ImportHalconScene(scene, out);
  ASSERT_EQ(take.rig.cameras.size(), 12u);
  EXPECT_EQ(take.rig.source_unit, "m");
  EXPECT_EQ(take.rig.source_unit_mm, 1000.0);
  EXPECT_TRUE(ValidateTake(out).ok()) << ValidateTake(out).Summary();

  const io::Mesh reference = io::ReadPly(out / "reference/reference.ply");
  ASSERT_GT(reference.vertices.size(), 10000u);
  for (const auto& cam : take.rig.cameras) {
    const cv::Mat bgra =
        io::ReadImage(take.FramePath(take.instants[0], cam.model.id), io::ImageMode::kBgra8);
    // Gray level at the projection of each reference point facing the camera,
    // sampled where it projects and 20 px to the side.
    size_t on_valid = 0;
    std::vector<double> reference_gray, image_gray, shifted_gray;
    const Eigen::Vector3d centre = cam.model.CentreWorld();
    for (size_t i = 0; i < reference.vertices.size(); ++i) {
      // Metres in the file, millimetres in the take.
      const Eigen::Vector3d world = reference.vertices[i].cast<double>() * take.rig.source_unit_mm;
      Eigen::Vector2d px;
      if (!cam.model.Project(world, &px)) continue;
      const int x = static_cast<int>(std::lround(px.x()));
      const int y = static_cast<int>(std::lround(px.y()));
      if (x < 20 || y < 0 || x >= bgra.cols || y >= bgra.rows) continue;
      if (bgra.at<cv::Vec4b>(y, x)[3] != 255) continue;
      ++on_valid;
      if (reference.normals[i].cast<double>().dot(centre - world) <= 0) continue;  // back side
      reference_gray.push_back(reference.colors[i].x());
      image_gray.push_back(bgra.at<cv::Vec4b>(y, x)[0]);
      shifted_gray.push_back(bgra.at<cv::Vec4b>(y, x - 20)[0]);
    }
    const double fraction = static_cast<double>(on_valid) / reference.vertices.size();
    EXPECT_GT(fraction, 0.99) << cam.model.id;
    // The reference's colours were taken from these images: where the pose is right,
    // the image texture under the projected points follows the points' own colours,
    // and stops following them when the projection is moved off by 20 px.
    const double r = Correlation(reference_gray, image_gray);
    const double r_shifted = Correlation(reference_gray, shifted_gray);
    // Measured on the 4 shared scenes: r 0.43..0.81, shifted at most 0.41, gap >= 0.23.
    EXPECT_GT(r, 0.35) << cam.model.id;
    EXPECT_GT(r, r_shifted + 0.15) << cam.model.id << " shifted " << r_shifted;
  }
}

INSTANTIATE_TEST_SUITE_P(Robovision, HalconImportTest,
                         ::testing::Values("2016_10_24__17_43_02", "2016_10_24__17_44_40",
                                           "2016_10_24__18_26_08", "2016_10_25__12_11_32"));

TEST(MiddleburyImport, BoundingBoxProjectsIntoEveryView) {
  const fs::path par = kShared / "data/middlebury-mv/templeSparseRing/templeSR_par.txt";
  if (!fs::exists(par)) GTEST_SKIP() << "no shared data at " << par;
  const dome::testing::TempDir tmp;
  const fs::path out = tmp.path();
  const Take take = ImportMiddlebury(par, out);
  ASSERT_EQ(take.rig.cameras.size(), 16u);
  EXPECT_EQ(take.rig.cameras[0].model.id, "templeSR0001");
  EXPECT_TRUE(ValidateTake(out).ok()) << ValidateTake(out).Summary();
  // The README's tight bounding box, in metres.
  const Eigen::Vector3d lo(-0.073568, 0.021728, -0.012445), hi(0.028855, 0.181892, 0.062736);
  for (const auto& cam : take.rig.cameras) {
    for (int corner = 0; corner < 8; ++corner) {
      const Eigen::Vector3d p((corner & 1 ? hi : lo).x(), (corner & 2 ? hi : lo).y(),
                              (corner & 4 ? hi : lo).z());
      const Eigen::Vector3d world_mm = p * take.rig.source_unit_mm;
      EXPECT_GT(cam.model.WorldToCamera(world_mm).z(), 0) << cam.model.id;
      Eigen::Vector2d px;
      ASSERT_TRUE(cam.model.Project(world_mm, &px));
      EXPECT_GE(px.x(), 0) << cam.model.id;
      EXPECT_GE(px.y(), 0) << cam.model.id;
      EXPECT_LT(px.x(), cam.model.width_px) << cam.model.id;
      EXPECT_LT(px.y(), cam.model.height_px) << cam.model.id;
    }
    // The camera stands at a plausible distance: the temple ring has a radius of
    // about half a metre, so a unit error (metres vs mm) would be off by 1000x.
    const double distance_mm = cam.model.CentreWorld().norm();
    EXPECT_GT(distance_mm, 300);
    EXPECT_LT(distance_mm, 1000);
  }
}

TEST(Import, ErrorsNameTheSource) {
  const dome::testing::TempDir tmp;
  const fs::path out = tmp.path();
  ExpectInputError([&] { ImportHalconScene("/nonexistent/scene", out / "t"); },
                   {"/nonexistent/scene", "not a folder"});
  ExpectInputError([&] { ImportHalconScene(out, out / "t"); }, {"no HALCON cameras"});
  ExpectInputError([&] { ImportMiddlebury(out / "none_par.txt", out / "t"); },
                   {"none_par.txt", "missing"});
  ImportOptions bad;
  bad.instant = "tomorrow";
  ExpectInputError([&] { ImportHalconScene(out, out / "t", bad); }, {"--instant", "HH-MM-SS-FF"});
}

TEST(Import, RefusesToOverwriteWithoutPermission) {
  const fs::path par = kShared / "data/middlebury-mv/templeSparseRing/templeSR_par.txt";
  if (!fs::exists(par)) GTEST_SKIP();
  const dome::testing::TempDir tmp;
  const fs::path out = tmp.path();
  ImportMiddlebury(par, out);
  ExpectInputError([&] { ImportMiddlebury(par, out); }, {"rig.json", "--overwrite"});
  ImportOptions options;
  options.overwrite = true;
  EXPECT_NO_THROW(ImportMiddlebury(par, out, options));
}

}  // namespace
}  // namespace dome::take

namespace dome::take {
namespace {

// cv::projectPoints of world points (mm) with a Panoptic camera's own K, distCoef, R
// and t (centimetres), read from the source JSON, not from the take.
std::vector<cv::Point2d> OpenCvProjection(const core::Json& cam,
                                          const std::vector<Eigen::Vector3d>& world_mm) {
  cv::Mat k(3, 3, CV_64F), r(3, 3, CV_64F), t(3, 1, CV_64F), d(1, 5, CV_64F);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      k.at<double>(i, j) = cam["K"][i][j].get<double>();
      r.at<double>(i, j) = cam["R"][i][j].get<double>();
    }
    t.at<double>(i) = cam["t"][i][0].get<double>();
  }
  for (int i = 0; i < 5; ++i) d.at<double>(i) = cam["distCoef"][i].get<double>();
  std::vector<cv::Point3d> cm;
  for (const auto& p : world_mm) cm.emplace_back(p.x() / 10, p.y() / 10, p.z() / 10);
  cv::Mat rvec;
  cv::Rodrigues(r, rvec);
  std::vector<cv::Point2d> px;
  cv::projectPoints(cm, rvec, t, k, d, px);
  return px;
}

TEST(PanopticImport, ThreeInstantTakeWhoseLensReprojectsTheCalibrationExactly) {
  const fs::path dir = kShared / "data/panoptic";
  if (!fs::exists(dir)) GTEST_SKIP() << "no shared data at " << dir;
  const dome::testing::TempDir tmp;
  const Take take = ImportPanoptic(dir / "camera_parameters.json", dir / "hd", tmp.path());
  ASSERT_EQ(take.rig.cameras.size(), 5u);
  EXPECT_EQ(take.instants, (std::vector<std::string>{"00-02-30-00", "00-03-03-24", "00-03-48-19"}));
  EXPECT_TRUE(ValidateTake(tmp.path()).ok()) << ValidateTake(tmp.path()).Summary();
  const core::Json doc = core::Json::parse(io::ReadFileBytes(dir / "camera_parameters.json"));
  double worst = 0;
  size_t points = 0;
  for (const auto& rc : take.rig.cameras) {
    const geometry::TsaiCamera& m = rc.model;
    EXPECT_TRUE(m.lens.Any()) << m.id;
    core::Json src;
    for (const auto& c : doc["cameras"])
      if (c["name"] == m.id) src = c;
    ASSERT_FALSE(src.is_null()) << m.id;
    // A grid of image points (corners included) sent 1.5 to 6 m out along their rays by
    // the take's camera, then projected by both.
    std::vector<Eigen::Vector3d> world;
    std::vector<Eigen::Vector2d> ours;
    for (int gy = 0; gy <= 10; ++gy) {
      for (int gx = 0; gx <= 16; ++gx) {
        const Eigen::Vector2d px(gx * (m.width_px - 1) / 16.0, gy * (m.height_px - 1) / 10.0);
        const Eigen::Vector3d p = m.BackProjectAtDepth(px, 1500.0 + 300.0 * ((gx + gy) % 16));
        Eigen::Vector2d back;
        ASSERT_TRUE(m.Project(p, &back));
        EXPECT_LT((back - px).norm(), 1e-6) << m.id << " at " << px.transpose();
        world.push_back(p);
        ours.push_back(back);
      }
    }
    const std::vector<cv::Point2d> theirs = OpenCvProjection(src, world);
    for (size_t i = 0; i < world.size(); ++i) {
      worst = std::max(worst, std::hypot(ours[i].x() - theirs[i].x, ours[i].y() - theirs[i].y));
      ++points;
    }
  }
  EXPECT_LT(worst, 0.01) << "px over " << points << " points";
  std::printf("panoptic: our lens vs cv::projectPoints: max %.2e px over %zu points\n", worst,
              points);
}

TEST(PanopticImport, BadCalibrationIsNamed) {
  const dome::testing::TempDir tmp;
  const fs::path dir = tmp / "src";
  fs::create_directories(dir / "hd" / "00_01");
  io::WriteFileAtomically(dir / "camera_parameters.json",
                          R"({"cameras": [{"name": "00_01", "resolution": [4, 4],
                              "K": [[1, 0, 2], [0, 1, 2], [0, 0, 1]], "distCoef": [0, 0, 0, 0],
                              "R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "t": [[0], [0], [0]]}]})");
  ExpectInputError(
      [&] { ImportPanoptic(dir / "camera_parameters.json", dir / "hd", tmp / "take"); },
      {"camera_parameters.json", "'00_01'", "distCoef", "expected 5 numbers"});
  io::WriteFileAtomically(dir / "camera_parameters.json",
                          R"({"cameras": [{"name": "00_01", "resolution": [4, 4],
                              "K": [[1, 0, 2], [0, 1, 2], [0, 0, 1]], "distCoef": [0, 0, 0, 0, 0],
                              "R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "t": [[0], [0], [0]]}]})");
  ExpectInputError(
      [&] { ImportPanoptic(dir / "camera_parameters.json", dir / "hd", tmp / "take"); },
      {"00_01", "no frames"});
  EXPECT_FALSE(fs::exists(tmp / "take"));  // nothing written
}

}  // namespace
}  // namespace dome::take
