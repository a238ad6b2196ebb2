// The OpenCV FileStorage and video importers, the Panoptic rig-only and --cameras
// paths, and what every importer promises on bad input: a named error and nothing
// written (no take, no staging folder, an existing take untouched).
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/persistence.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "io/file_util.h"
#include "schema/rig_json.h"
#include "take/import.h"
#include "take/validate.h"
#include "take_fixture.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::take {
namespace {

namespace fs = std::filesystem;
using dome::testing::ExpectInputError;

const fs::path kShared = DOME_SHARED_DIR;

// Nothing but `keep` in `dir`: no take, no staging folder left by a failed import.
void ExpectOnly(const fs::path& dir, const std::vector<std::string>& keep) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  std::vector<std::string> want = keep;
  std::sort(want.begin(), want.end());
  EXPECT_EQ(names, want);
}

// A camera as OpenCV's calibration tools describe one, 1 m in front of the origin.
struct CvCamera {
  cv::Mat k = (cv::Mat_<double>(3, 3) << 410.5, 0, 79.25, 0, 405.0, 61.5, 0, 0, 1);
  cv::Mat d = (cv::Mat_<double>(1, 5) << -0.21, 0.07, 0.0011, -0.0007, -0.012);
  cv::Mat rvec = (cv::Mat_<double>(3, 1) << 0.05, -0.31, 0.02);
  cv::Mat tvec = (cv::Mat_<double>(3, 1) << 0.02, -0.01, 1.0);  // metres
  int width = 160, height = 120;
};

// Writes the camera as `file` (.yml, .xml or .json: cv::FileStorage picks by name),
// with R as a matrix or as rvec, the size as image_width/height or image_size.
void WriteCvCamera(const fs::path& file, const CvCamera& c, bool rotation_matrix, bool size_pair) {
  cv::FileStorage fs(file.string(), cv::FileStorage::WRITE);
  if (size_pair) {
    fs << "image_size" << std::vector<int>{c.width, c.height};
  } else {
    fs << "image_width" << c.width << "image_height" << c.height;
  }
  fs << "camera_matrix" << c.k << "distortion_coefficients" << c.d;
  if (rotation_matrix) {
    cv::Mat r;
    cv::Rodrigues(c.rvec, r);
    fs << "R" << r;
  } else {
    fs << "rvec" << c.rvec;
  }
  fs << "T" << c.tvec;
}

cv::Mat Noise(int w, int h, int seed, int type = CV_8UC3) {
  cv::Mat m(h, w, type);
  cv::RNG rng(seed);
  rng.fill(m, cv::RNG::UNIFORM, 0, 256);
  return m;
}

TEST(OpenCvImport, FileStorageCamerasProjectAsOpenCvDoes) {
  const dome::testing::TempDir tmp;
  fs::create_directories(tmp / "calib");
  fs::create_directories(tmp / "images");
  CvCamera a, b;
  b.rvec = (cv::Mat_<double>(3, 1) << -0.1, 0.25, 0.0);
  b.tvec = (cv::Mat_<double>(3, 1) << -0.03, 0.0, 1.1);
  b.d = (cv::Mat_<double>(1, 4) << -0.1, 0.01, 0.0, 0.0);
  WriteCvCamera(tmp / "calib/left.yml", a, false, false);
  WriteCvCamera(tmp / "calib/right.json", b, true, true);
  cv::imwrite((tmp / "images/left.png").string(), Noise(160, 120, 1));
  cv::imwrite((tmp / "images/right.jpg").string(), Noise(160, 120, 2));
  const Take take = ImportOpenCv(tmp / "calib", tmp / "images", tmp / "take", 1000.0);
  ASSERT_EQ(take.rig.cameras.size(), 2u);
  EXPECT_EQ(take.instants, std::vector<std::string>{"00-00-00-00"});
  EXPECT_TRUE(ValidateTake(take.dir).ok()) << ValidateTake(take.dir).Summary();
  EXPECT_EQ(io::ReadFileBytes(take.FramePath("00-00-00-00", "left")),
            io::ReadFileBytes(tmp / "images/left.png"));
  const geometry::Rig rig = schema::ReadRig(take.RigPath());  // as written, not as held
  for (const auto& [id, c] : {std::pair{"left", a}, std::pair{"right", b}}) {
    const geometry::TsaiCamera* m = nullptr;
    for (const auto& rc : rig.cameras)
      if (rc.model.id == id) m = &rc.model;
    ASSERT_NE(m, nullptr) << id;
    std::vector<cv::Point3d> world_m;
    for (int i = 0; i < 50; ++i) {
      world_m.emplace_back(0.2 * std::sin(i), 0.15 * std::cos(1.7 * i), 0.1 * std::sin(0.3 * i));
    }
    std::vector<cv::Point2d> theirs;
    cv::projectPoints(world_m, c.rvec, c.tvec, c.k, c.d, theirs);
    for (size_t i = 0; i < world_m.size(); ++i) {
      Eigen::Vector2d ours;
      ASSERT_TRUE(
          m->Project(1000.0 * Eigen::Vector3d(world_m[i].x, world_m[i].y, world_m[i].z), &ours));
      EXPECT_NEAR(ours.x(), theirs[i].x, 1e-6) << id;
      EXPECT_NEAR(ours.y(), theirs[i].y, 1e-6) << id;
    }
  }
}

TEST(OpenCvImport, FrameFoldersGiveAMultiInstantTakeAndNoImagesARigOnlyOne) {
  const dome::testing::TempDir tmp;
  fs::create_directories(tmp / "calib");
  for (const char* id : {"a", "b"}) {
    WriteCvCamera(tmp / "calib" / (std::string(id) + ".xml"), CvCamera{}, true, false);
    fs::create_directories(tmp / "images" / id);
    for (int f : {3, 37}) {
      cv::imwrite((tmp / "images" / id / ("frame_" + std::to_string(f) + ".png")).string(),
                  Noise(160, 120, f));
    }
  }
  const Take take = ImportOpenCv(tmp / "calib", tmp / "images", tmp / "take", 1.0);
  EXPECT_EQ(take.instants, (std::vector<std::string>{"00-00-00-03", "00-00-01-07"}));
  EXPECT_TRUE(ValidateTake(take.dir).ok()) << ValidateTake(take.dir).Summary();
  const Take rig_only = ImportOpenCv(tmp / "calib", {}, tmp / "rig", 1.0);
  EXPECT_TRUE(rig_only.instants.empty());
  EXPECT_EQ(schema::ReadRig(rig_only.RigPath()).cameras.size(), 2u);
  ExpectOnly(tmp.path(), {"calib", "images", "rig", "take"});
}

TEST(OpenCvImport, BadInputIsNamedAndNothingIsWritten) {
  const dome::testing::TempDir tmp;
  const fs::path calib = tmp / "calib", images = tmp / "images";
  fs::create_directories(calib);
  fs::create_directories(images);
  WriteCvCamera(calib / "a.yml", CvCamera{}, false, false);
  cv::imwrite((images / "a.png").string(), Noise(160, 120, 1));
  const auto expect = [&](std::initializer_list<std::string> parts) {
    ExpectInputError([&] { ImportOpenCv(calib, images, tmp / "take", 1.0); }, parts);
    ExpectOnly(tmp.path(), {"calib", "images"});
  };
  // A field missing.
  io::WriteFileAtomically(calib / "b.yml",
                          "%YAML:1.0\n---\nimage_width: 160\nimage_height: 120\n"
                          "distortion_coefficients: [0, 0, 0, 0]\nR: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
                          "T: [0, 0, 1000]\n");
  expect({"b.yml", "camera matrix", "missing", "camera_matrix, cameraMatrix, K"});
  // A NaN.
  io::WriteFileAtomically(calib / "b.yml",
                          "%YAML:1.0\n---\nimage_width: 160\nimage_height: 120\n"
                          "camera_matrix: [400, 0, 80, 0, .nan, 60, 0, 0, 1]\n"
                          "distortion_coefficients: [0, 0, 0, 0]\nR: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
                          "T: [0, 0, 1000]\n");
  expect({"b.yml", "camera matrix", "not finite"});
  // A lens dome cannot hold: the error it would make is given.
  CvCamera rational;
  rational.d = (cv::Mat_<double>(1, 8) << -0.2, 0.05, 0, 0, 0, 0.01, 0.002, 0.1);
  WriteCvCamera(calib / "b.yml", rational, false, false);
  expect({"b.yml", "distortion", "k1 k2 p1 p2 k3", "px"});
  // Not a FileStorage file at all.
  io::WriteFileAtomically(calib / "b.yml", "this is { not yaml");
  expect({"b.yml"});
  // A camera without images; then an image of the wrong size.
  WriteCvCamera(calib / "b.yml", CvCamera{}, false, false);
  expect({"b", "has no image"});
  cv::imwrite((images / "b.png").string(), Noise(150, 120, 2));
  expect({"b.png", "150x120", "calibrated for 160x120"});
  ExpectInputError([&] { ImportOpenCv(calib, images, tmp / "take", 0.0); }, {"--mm-per-unit"});
}

TEST(TakeWriter, AFailedImportLeavesTheOldTakeAsItWas) {
  const dome::testing::TempDir tmp;
  fs::create_directories(tmp / "calib");
  fs::create_directories(tmp / "images");
  WriteCvCamera(tmp / "calib/a.yml", CvCamera{}, false, false);
  cv::imwrite((tmp / "images/a.png").string(), Noise(160, 120, 1));
  ImportOpenCv(tmp / "calib", tmp / "images", tmp / "take", 1.0);
  const std::string before = io::ReadFileBytes(tmp / "take/rig.json");
  ExpectInputError([&] { ImportOpenCv(tmp / "calib", tmp / "images", tmp / "take", 1.0); },
                   {"rig.json", "--overwrite"});
  ImportOptions overwrite;
  overwrite.overwrite = true;
  cv::imwrite((tmp / "images/a.png").string(), Noise(100, 120, 1));  // now wrong
  ExpectInputError(
      [&] { ImportOpenCv(tmp / "calib", tmp / "images", tmp / "take", 2.0, overwrite); },
      {"a.png", "100x120"});
  EXPECT_EQ(io::ReadFileBytes(tmp / "take/rig.json"), before);
  EXPECT_TRUE(fs::exists(tmp / "take/frames/00-00-00-00/a.png"));
  ExpectOnly(tmp.path(), {"calib", "images", "take"});
  // A folder that holds something other than a take is not replaced.
  fs::create_directories(tmp / "other");
  io::WriteFileAtomically(tmp / "other/notes.txt", "mine");
  ExpectInputError([&] { ImportOpenCv(tmp / "calib", {}, tmp / "other", 1.0, overwrite); },
                   {"other", "not empty", "no take"});
}

TEST(PanopticImport, TheWholeDomeAsARigAndASubsetWithImages) {
  const fs::path dir = kShared / "data/panoptic";
  if (!fs::exists(dir)) GTEST_SKIP() << "no shared data at " << dir;
  const dome::testing::TempDir tmp;
  const Take dome520 = ImportPanoptic(dir / "calibration_160906_band1.json", {}, tmp / "dome");
  EXPECT_TRUE(dome520.instants.empty());
  const geometry::Rig rig = schema::ReadRig(dome520.RigPath());
  ASSERT_EQ(rig.cameras.size(), 520u);
  int vga = 0;
  for (const auto& rc : rig.cameras) vga += rc.model.width_px == 640 && rc.model.height_px == 480;
  EXPECT_EQ(vga, 479);
  PanopticOptions two;
  two.cameras = {"00_12", "00_03"};
  const Take take = ImportPanoptic(dir / "camera_parameters.json", dir / "hd", tmp / "two", two);
  ASSERT_EQ(take.rig.cameras.size(), 2u);
  EXPECT_EQ(take.instants.size(), 3u);
  two.cameras = {"00_03", "00_00"};  // calibrated, not filmed in this excerpt
  ExpectInputError(
      [&] { ImportPanoptic(dir / "camera_parameters.json", dir / "hd", tmp / "bad", two); },
      {"00_00", "--cameras", "no frames"});
  two.cameras = {"99_99"};
  ExpectInputError(
      [&] { ImportPanoptic(dir / "camera_parameters.json", dir / "hd", tmp / "bad", two); },
      {"--cameras", "99_99", "not in"});
  ExpectOnly(tmp.path(), {"dome", "two"});
}

TEST(PanopticImport, MissingFieldsAndNotANumberAreNamed) {
  const dome::testing::TempDir tmp;
  const fs::path json = tmp / "calib.json";
  io::WriteFileAtomically(json, R"({"cameras": [{"name": "00_01", "resolution": [4, 4],
      "distCoef": [0, 0, 0, 0, 0], "R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "t": [[0], [0], [0]]}]})");
  ExpectInputError([&] { ImportPanoptic(json, {}, tmp / "take"); },
                   {"calib.json", "cameras[0] '00_01'.K", "missing"});
  io::WriteFileAtomically(json, R"({"cameras": [{"name": "00_01", "resolution": [4, 4],
      "K": [[NaN, 0, 2], [0, 1, 2], [0, 0, 1]], "distCoef": [0, 0, 0, 0, 0],
      "R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "t": [[0], [0], [0]]}]})");
  ExpectInputError([&] { ImportPanoptic(json, {}, tmp / "take"); }, {"calib.json", "not JSON"});
  io::WriteFileAtomically(json, R"({"cameras": [{"name": "00_01", "resolution": [4, 4],
      "K": [[1, 0, 2], [0, 1, 2], [0, 0, 1]], "distCoef": [0, 0, 0, 0, 0],
      "R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "t": [[0], ["x"], [0]]}]})");
  ExpectInputError([&] { ImportPanoptic(json, {}, tmp / "take"); },
                   {"'00_01'.t", "expected numbers"});
  ExpectOnly(tmp.path(), {"calib.json"});
}

// Per-camera videos, lossless (FFV1), of a ring rig's frames; camera c's video
// starts at timeline frame offsets[c].
class VideoImport : public ::testing::Test {
 protected:
  void SetUp() override {
    rig_ = testing::MakeRingRig(3, 64, 48);
    fs::create_directories(tmp_ / "videos");
    for (size_t c = 0; c < rig_.cameras.size(); ++c) {
      cv::VideoWriter writer((tmp_ / "videos" / (rig_.cameras[c].model.id + ".mkv")).string(),
                             cv::VideoWriter::fourcc('F', 'F', 'V', '1'), 25.0, cv::Size(64, 48));
      ASSERT_TRUE(writer.isOpened()) << "OpenCV cannot write FFV1 video";
      for (int i = 0; i < frames_; ++i) writer.write(Frame(c, i + offsets_[c]));
    }
  }
  // The image of camera c at timeline frame g.
  static cv::Mat Frame(size_t c, int g) { return Noise(64, 48, int(1000 * c + g)); }

  void ExpectFrames(const Take& take, const std::vector<int>& timeline) {
    ASSERT_EQ(take.instants.size(), timeline.size());
    for (size_t t = 0; t < timeline.size(); ++t) {
      for (size_t c = 0; c < rig_.cameras.size(); ++c) {
        const cv::Mat got = cv::imread(take.FramePath(take.instants[t], rig_.cameras[c].model.id),
                                       cv::IMREAD_UNCHANGED);
        ASSERT_FALSE(got.empty());
        EXPECT_EQ(cv::norm(got, Frame(c, timeline[t]), cv::NORM_INF), 0)
            << "camera " << c << " timeline frame " << timeline[t];
      }
    }
  }

  VideoImportOptions Options() const {
    VideoImportOptions o;
    for (size_t c = 0; c < rig_.cameras.size(); ++c) {
      o.offset_frames[rig_.cameras[c].model.id] = offsets_[c];
    }
    return o;
  }

  dome::testing::TempDir tmp_;
  geometry::Rig rig_;
  const int frames_ = 30;
  const std::vector<int> offsets_ = {0, 4, 2};  // the cameras cover timeline 4..29
};

TEST_F(VideoImport, OffsetsLineTheCamerasUpOnOneTimeline) {
  const Take all = ImportVideo(rig_, tmp_ / "videos", tmp_ / "all", Options());
  std::vector<int> common;
  for (int g = 4; g <= 29; ++g) common.push_back(g);
  ExpectFrames(all, common);
  EXPECT_EQ(all.instants.front(), "00-00-00-04");
  EXPECT_EQ(all.instants.back(), "00-00-01-04");  // frame 29 at 25 frames a second
  EXPECT_TRUE(ValidateTake(all.dir).ok()) << ValidateTake(all.dir).Summary();

  VideoImportOptions every = Options();
  every.range = {"00:00:00:05", "20"};
  every.every = 7;
  ExpectFrames(ImportVideo(rig_, tmp_ / "videos", tmp_ / "every", every), {5, 12, 19});

  // A start timecode instead of an offset says the same.
  VideoImportOptions listed = Options();
  listed.offset_frames.erase("c1");
  listed.start_timecodes["c1"] = "00:00:00:04";
  listed.instants = {"28", "6", "00:00:00:10"};
  ExpectFrames(ImportVideo(rig_, tmp_ / "videos", tmp_ / "listed", listed), {6, 10, 28});
}

TEST_F(VideoImport, ShortUnreadableOrMissingVideosAreNamedAndNothingIsWritten) {
  const auto expect = [&](const VideoImportOptions& o, std::initializer_list<std::string> parts) {
    ExpectInputError([&] { ImportVideo(rig_, tmp_ / "videos", tmp_ / "take", o); }, parts);
    ExpectOnly(tmp_.path(), {"videos"});
  };
  VideoImportOptions late = Options();
  late.range = {"10", "31"};  // c0 ends at timeline frame 29
  expect(late, {"c0.mkv", "holds 30 frames", "timeline 0..29", "up to 31"});
  VideoImportOptions early = Options();
  early.instants = {"2"};  // c1 starts at 4
  expect(early, {"c1.mkv", "starts at timeline frame 4"});
  VideoImportOptions bad_tc = Options();
  bad_tc.range = {"00:00:00:27", "40"};  // frame 27 of a 25-frame second
  expect(bad_tc, {"--range", "00:00:00:27", "25 frames a second"});
  // A file cut short: its header still promises 30 frames; the read fails, named,
  // mid-stream.
  const std::string whole = io::ReadFileBytes(tmp_ / "videos/c2.mkv");
  io::WriteFileAtomically(tmp_ / "videos/c2.mkv", whole.substr(0, whole.size() / 3));
  expect(Options(), {"c2.mkv", "before frame"});
  io::WriteFileAtomically(tmp_ / "videos/c2.mkv", "not a video at all");
  expect(Options(), {"c2.mkv", "cannot be opened as a video"});
  fs::remove(tmp_ / "videos/c2.mkv");
  expect(Options(), {"c2", "has no video"});
  cv::VideoWriter small((tmp_ / "videos/c2.mkv").string(),
                        cv::VideoWriter::fourcc('F', 'F', 'V', '1'), 25.0, cv::Size(32, 48));
  for (int i = 0; i < 5; ++i) small.write(Noise(32, 48, i));
  small.release();
  expect(Options(), {"c2.mkv", "32x48", "calibrated for 64x48"});
}

}  // namespace
}  // namespace dome::take
