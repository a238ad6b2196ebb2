// Two-stage calibration of the synthetic small take (6 cameras, at 320 x 240): point
// detection against the renderer's truth, the calibrated rig against the true one, and
// the bad-input errors of the pipeline.
#include "calib/calibrate.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

#include "calib/detect.h"
#include "calib/target.h"
#include "io/image_io.h"
#include "io/ply.h"
#include "schema/rig_json.h"
#include "synth/calibration.h"
#include "synth/synth.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::calib {
namespace {

namespace fs = std::filesystem;

class SmallTake : public ::testing::Test {
 protected:
  // ctest runs each test in its own process, several at once: every process renders
  // its own take into its own folder.
  static void SetUpTestSuite() {
    tmp_ = std::make_unique<dome::testing::TempDir>();
    dir_ = tmp_->path() / "take";
    synth::SynthOptions options;
    // The small preset's 160 x 120 images make its dots 1-2 px across, below what a
    // blob detector can place to 0.1 px: the same 6 cameras at 320 x 240.
    options.preset = "small";
    options.instants = 1;
    options.width_px = 320;
    options.height_px = 240;
    options.write_tape = false;
    options.overwrite = true;
    synth::GenerateTake(options, dir_);
  }
  // A copy of the take's rig and calib/ to break.
  static fs::path Copy(const std::string& name) {
    const fs::path out = tmp_->path() / ("broken_" + name);
    fs::remove_all(out);
    fs::create_directories(out);
    fs::copy(dir_ / "calib", out / "calib", fs::copy_options::recursive);
    fs::copy(dir_ / "rig.json", out / "rig.json");
    return out;
  }
  static void TearDownTestSuite() { tmp_.reset(); }
  static std::unique_ptr<dome::testing::TempDir> tmp_;
  static fs::path dir_;
};
std::unique_ptr<dome::testing::TempDir> SmallTake::tmp_;
fs::path SmallTake::dir_;

TEST_F(SmallTake, DetectsDotsWhereTheRendererPutThem) {
  const geometry::Rig rig = schema::ReadRig(dir_ / "rig.json");
  for (const char* stage : {"stage1", "stage2"}) {
    const Target target = ReadTarget(dir_ / "calib" / stage / "target.json");
    const GridLayout layout = InferGridLayout(target);
    for (const auto& cam : rig.cameras) {
      const CalibView view = ReadCalibView(dir_ / "calib" / stage / (cam.model.id + ".json"));
      const cv::Mat gray = io::ReadImage(view.image, io::ImageMode::kGray8);
      const DotDetection det = DetectDotTarget(gray, target, layout, {}, view.image.string());
      // the detector labels the grids; plain marks are found later, from the pose
      const int grid_truth = static_cast<int>(
          std::count_if(view.points.begin(), view.points.end(), [&](const ImagePoint& t) {
            return target.grid_points == 0 || t.id < target.grid_points;
          }));
      int matched = 0;
      double worst = 0;
      for (const auto& p : det.points) {
        const auto it = std::find_if(view.points.begin(), view.points.end(),
                                     [&](const ImagePoint& t) { return t.id == p.id; });
        if (it == view.points.end()) continue;  // found though the truth skips it (near the border)
        ++matched;
        worst = std::max(worst, (it->pixel - p.pixel).norm());
      }
      // every identified dot is the right one, to a fraction of a pixel
      EXPECT_LT(worst, 0.6) << stage << " " << cam.model.id << ": " << det.BriefReport();
      EXPECT_GE(matched, static_cast<int>(0.9 * grid_truth))
          << stage << " " << cam.model.id << ": " << det.BriefReport();
    }
  }
}

TEST_F(SmallTake, CalibratedRigProjectsTheMeshLikeTheTrueRig) {
  const geometry::Rig truth = schema::ReadRig(dir_ / "rig.json");
  CalibrateOptions options;
  const CalibrationResult result = CalibrateTake(dir_, truth, options);
  ASSERT_EQ(result.rig.cameras.size(), truth.cameras.size());
  // Written and read back, as `dome calibrate` does.
  const fs::path rig_path = tmp_->path() / "calibrated_rig.json";
  schema::WriteRig(result.rig, rig_path);
  const geometry::Rig calibrated = schema::ReadRig(rig_path);
  const io::Mesh mesh = io::ReadPly(dir_ / "truth" / synth::InstantName(0) / "mesh.ply");
  std::vector<double> diffs;
  for (size_t c = 0; c < truth.cameras.size(); ++c) {
    const auto& t = truth.cameras[c].model;
    const auto& e = calibrated.cameras[c].model;
    for (const auto& v : mesh.vertices) {
      Eigen::Vector2d pt, pe;
      if (!t.Project(v.cast<double>(), &pt) || !e.Project(v.cast<double>(), &pe)) continue;
      if (pt.x() < 0 || pt.y() < 0 || pt.x() > t.width_px - 1 || pt.y() > t.height_px - 1) continue;
      diffs.push_back((pt - pe).norm());
    }
    EXPECT_LT(result.cameras[c].rms_px, 0.3) << result.BriefReport();
    // every pose of the object used, and the intrinsics against the truth (the paper
    // dome's acceptance figures are 0.1% and 2%; margins for 6 cameras at 320 x 240)
    EXPECT_EQ(result.cameras[c].stage1.views, synth::kStage1Poses);
    EXPECT_TRUE(result.cameras[c].stage1.skipped_views.empty());
    EXPECT_NEAR(e.focal_mm / t.focal_mm, 1.0, 0.003) << t.id;
    EXPECT_NEAR(e.kappa1_per_mm2 / t.kappa1_per_mm2, 1.0, 0.06) << t.id;
    EXPECT_NEAR(e.cx_px, t.cx_px, 1.0) << t.id;
    EXPECT_NEAR(e.cy_px, t.cy_px, 1.0) << t.id;
    // the floor's plain marks around the grid found and used: the pose against the
    // truth (the paper dome's acceptance figures are 2 mm and 0.05 deg)
    EXPECT_GE(result.cameras[c].stage2.points, 25 + 10) << t.id;
    EXPECT_LT((e.CentreWorld() - t.CentreWorld()).norm(), 2.0) << t.id;
    EXPECT_LT(Eigen::AngleAxisd(e.rotation * t.rotation.transpose()).angle() * 180 / M_PI, 0.05)
        << t.id;
  }
  ASSERT_GT(diffs.size(), 1000u);
  std::nth_element(diffs.begin(), diffs.begin() + diffs.size() / 2, diffs.end());
  EXPECT_LT(diffs[diffs.size() / 2], 0.3) << result.BriefReport();
  std::printf(
      "mesh projections, calibrated vs true rig: median %.4f px over %zu (camera, vertex)\n",
      diffs[diffs.size() / 2], diffs.size());
  const std::string json = result.ReportJson();
  EXPECT_NE(json.find("\"worst_points\""), std::string::npos);
  EXPECT_NE(json.find("\"sigma\""), std::string::npos);
}

TEST_F(SmallTake, MissingCalibrationImage) {
  const fs::path take = Copy("image");
  fs::remove(take / "calib" / "stage1" / "c02.png");
  const geometry::Rig rig = schema::ReadRig(take / "rig.json");
  testing::ExpectInputError([&] { CalibrateTake(take, rig, {}); },
                            {"stage1/c02.json: image", "c02.png", "does not exist"});
}

TEST_F(SmallTake, MissingViewFile) {
  const fs::path take = Copy("view");
  fs::remove(take / "calib" / "stage2" / "c01.json");
  const geometry::Rig rig = schema::ReadRig(take / "rig.json");
  testing::ExpectInputError([&] { CalibrateTake(take, rig, {}); },
                            {"stage2/c01.json", "does not exist"});
}

TEST_F(SmallTake, CameraThatSeesTooFewFloorMarks) {
  const fs::path take = Copy("floor");
  // c03's floor marks image: everything but the top-left corner painted white.
  const fs::path image = take / "calib" / "stage2" / "c03.png";
  cv::Mat gray = io::ReadImage(image, io::ImageMode::kGray8);
  gray(cv::Rect(0, 0, gray.cols, gray.rows)).setTo(200);
  // keep a 2 x 2 block of marks' worth of the original image around the key mark
  const CalibView view = ReadCalibView(take / "calib" / "stage2" / "c03.json");
  const cv::Mat original = io::ReadImage(image, io::ImageMode::kGray8);
  int x0 = gray.cols, y0 = gray.rows, x1 = 0, y1 = 0;
  for (const auto& p : view.points) {
    if (p.id == 0 || p.id == 1 || p.id == 5 || p.id == 6) {
      x0 = std::min(x0, static_cast<int>(p.pixel.x()) - 3);
      y0 = std::min(y0, static_cast<int>(p.pixel.y()) - 3);
      x1 = std::max(x1, static_cast<int>(p.pixel.x()) + 4);
      y1 = std::max(y1, static_cast<int>(p.pixel.y()) + 4);
    }
  }
  ASSERT_LT(x0, x1);
  const cv::Rect keep = cv::Rect(x0, y0, x1 - x0, y1 - y0) & cv::Rect(0, 0, gray.cols, gray.rows);
  original(keep).copyTo(gray(keep));
  io::WriteImage(image, gray);
  const geometry::Rig rig = schema::ReadRig(take / "rig.json");
  testing::ExpectInputError(
      [&] { CalibrateTake(take, rig, {}); },
      {"stage2/c03.json", "camera c03 sees", "floor marks; stage 2 needs at least 6"});
}

// A further pose of the object whose image shows no dots is left out and reported;
// the camera calibrates from the others.
TEST_F(SmallTake, UnusableFurtherObjectPoseIsSkipped) {
  const fs::path take = Copy("pose");
  const std::vector<fs::path> views = ViewPaths(take / "calib" / "stage1", "c01");
  ASSERT_EQ(views.size(), static_cast<size_t>(synth::kStage1Poses));
  EXPECT_EQ(views[2].filename(), "c01.2.json");
  const fs::path image = take / "calib" / "stage1" / "c01.2.png";
  cv::Mat gray = io::ReadImage(image, io::ImageMode::kGray8);
  gray.setTo(200);
  io::WriteImage(image, gray);
  const geometry::Rig rig = schema::ReadRig(take / "rig.json");
  geometry::TsaiCamera calibrated;
  const CameraReport report = CalibrateCamera(
      rig.cameras[1], views, take / "calib" / "stage2" / "c01.json", {}, &calibrated);
  EXPECT_EQ(report.stage1.views, synth::kStage1Poses - 1);
  ASSERT_EQ(report.stage1.skipped_views.size(), 1u);
  EXPECT_NE(report.stage1.skipped_views[0].find("stage1.2"), std::string::npos);
  EXPECT_NEAR(calibrated.focal_mm / rig.cameras[1].model.focal_mm, 1.0, 0.003);
  EXPECT_NE(report.stage1.skipped_views[0].find("c01.2.png"), std::string::npos)
      << report.stage1.skipped_views[0];
}

// A take written before the floor's plain marks: its floor target is the 5 x 5 grid
// alone (no grid_points); the camera is placed from the grid, as before.
TEST_F(SmallTake, FloorTargetWithoutPlainMarksCalibratesFromTheGrid) {
  const fs::path take = Copy("grid_only");
  const Target floor = ReadTarget(take / "calib" / "stage2" / "target.json");
  ASSERT_EQ(floor.grid_points, 25);
  std::string json = R"({"format_version": 1, "frame": "world", "marker_radius_mm": )" +
                     std::to_string(floor.marker_radius_mm) + R"(, "key_marker_radius_mm": )" +
                     std::to_string(floor.key_marker_radius_mm) + R"(, "points": [)";
  for (const auto& p : floor.points) {
    if (p.id >= 25) continue;
    json += (p.id ? ", " : "") + std::string(R"({"id": )") + std::to_string(p.id) +
            R"(, "x_mm": )" + std::to_string(p.position_mm.x()) + R"(, "y_mm": )" +
            std::to_string(p.position_mm.y()) + "}";
  }
  std::ofstream(take / "calib" / "stage2" / "target.json") << json << "]}";
  const geometry::Rig rig = schema::ReadRig(take / "rig.json");
  geometry::TsaiCamera calibrated;
  const CameraReport report =
      CalibrateCamera(rig.cameras[0], ViewPaths(take / "calib" / "stage1", "c00"),
                      take / "calib" / "stage2" / "c00.json", {}, &calibrated);
  const auto& t = rig.cameras[0].model;
  EXPECT_LE(report.stage2.points, 25);
  EXPECT_GE(report.stage2.points, 20);
  EXPECT_LT(report.rms_px, 0.3);
  // the grid alone: the paper dome's worst cameras were ~3 mm and ~0.06 deg off
  EXPECT_LT((calibrated.CentreWorld() - t.CentreWorld()).norm(), 5.0);
  EXPECT_LT(Eigen::AngleAxisd(calibrated.rotation * t.rotation.transpose()).angle() * 180 / M_PI,
            0.1);
}

TEST_F(SmallTake, StoredPointsWithUnknownIdOrTooFew) {
  const fs::path take = Copy("stored");
  std::ofstream(take / "calib" / "stage1" / "c00.json")
      << R"({"format_version": 1, "camera": "c00", "image": "c00.png", "target": "target.json",
            "points": [{"id": 1, "x_px": 10, "y_px": 10}, {"id": 2, "x_px": 20, "y_px": 10},
                       {"id": 3, "x_px": 30, "y_px": 10}]})";
  const geometry::Rig rig = schema::ReadRig(take / "rig.json");
  CalibrateOptions options;
  options.use_stored_points = true;
  testing::ExpectInputError([&] { CalibrateTake(take, rig, options); },
                            {"stage1/c00.json", "3 calibration points", "at least 11"});
  std::ofstream(take / "calib" / "stage1" / "c00.json")
      << R"({"format_version": 1, "camera": "c00", "image": "c00.png",
            "points": [{"id": 9999, "x_px": 10, "y_px": 10}]})";
  testing::ExpectInputError([&] { CalibrateTake(take, rig, options); },
                            {"stage1/c00.json: points", "id 9999", "not in the target"});
}

TEST_F(SmallTake, TargetWithDuplicateIds) {
  const fs::path take = Copy("dup");
  const fs::path target = take / "calib" / "stage2" / "target.json";
  std::ofstream(target) << R"({"format_version": 1, "frame": "world", "marker_radius_mm": 45,
      "key_marker_radius_mm": 60, "points": [{"id": 0, "x_mm": 0}, {"id": 0, "x_mm": 300}]})";
  const geometry::Rig rig = schema::ReadRig(take / "rig.json");
  testing::ExpectInputError([&] { CalibrateTake(take, rig, {}); },
                            {"stage2/target.json: points[1].id", "duplicate id 0"});
}

}  // namespace
}  // namespace dome::calib
