#include "take/validate.h"

#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "schema/rig_json.h"
#include "take_fixture.h"
#include "testing/temp_dir.h"

namespace dome::take {
namespace {

namespace fs = std::filesystem;

class ValidateTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = tmp_.path();
    testing::WriteTake(dir_, testing::MakeRingRig(3, 40, 30), 2);
  }

  // The report must list exactly one problem, at a path ending in `where_suffix`,
  // whose text contains `what`.
  void ExpectOneProblem(const std::string& where_suffix, const std::string& what) {
    const TakeReport report = ValidateTake(dir_);
    ASSERT_EQ(report.problems.size(), 1u) << report.Summary();
    const auto& p = report.problems[0];
    EXPECT_TRUE(p.where.size() >= where_suffix.size() &&
                p.where.compare(p.where.size() - where_suffix.size(), where_suffix.size(),
                                where_suffix) == 0)
        << p.where;
    EXPECT_NE(p.what.find(what), std::string::npos) << p.what;
  }

  dome::testing::TempDir tmp_;
  fs::path dir_;
};

TEST_F(ValidateTest, ValidTakeIsOk) {
  const TakeReport report = ValidateTake(dir_);
  EXPECT_TRUE(report.ok()) << report.Summary();
  EXPECT_EQ(report.rig.cameras.size(), 3u);
  EXPECT_EQ(report.instants, (std::vector<std::string>{"00-00-01-00", "00-00-01-05"}));
  EXPECT_EQ(report.images_checked, 6);
  EXPECT_NE(report.Summary().find("instants: 2 (00:00:01:00 .. 00:00:01:05)"), std::string::npos);
  EXPECT_NO_THROW(OpenTake(dir_));
}

TEST_F(ValidateTest, MissingImage) {
  fs::remove(dir_ / "frames/00-00-01-05/c1.png");
  ExpectOneProblem("frames/00-00-01-05/c1.png", "missing image of camera 'c1'");
}

TEST_F(ValidateTest, SizeMismatch) {
  cv::imwrite((dir_ / "frames/00-00-01-00/c2.png").string(),
              cv::Mat(30, 41, CV_8UC1, cv::Scalar(9)));
  ExpectOneProblem("frames/00-00-01-00/c2.png",
                   "image is 41x30, rig.json says camera 'c2' is 40x30");
}

TEST_F(ValidateTest, CorruptImage) {
  std::ofstream(dir_ / "frames/00-00-01-00/c0.png") << "not a png";
  ExpectOneProblem("frames/00-00-01-00/c0.png", "unreadable or corrupt");
}

TEST_F(ValidateTest, WrongPixelKind) {
  cv::imwrite((dir_ / "frames/00-00-01-00/c0.png").string(),
              cv::Mat(30, 40, CV_16UC1, cv::Scalar(9)));
  ExpectOneProblem("frames/00-00-01-00/c0.png", "expected an 8-bit gray, BGR or BGRA image");
}

TEST_F(ValidateTest, UnknownCamera) {
  cv::imwrite((dir_ / "frames/00-00-01-00/c7.png").string(),
              cv::Mat(30, 40, CV_8UC1, cv::Scalar(9)));
  ExpectOneProblem("frames/00-00-01-00/c7.png", "unknown camera id 'c7'");
}

TEST_F(ValidateTest, BadInstantName) {
  fs::create_directories(dir_ / "frames/instant-one");
  ExpectOneProblem("frames/instant-one", "HH-MM-SS-FF");
}

TEST_F(ValidateTest, BadRigJson) {
  std::ofstream(dir_ / "rig.json")
      << R"({"format_version": 1, "cameras": [{"id": "c0", "lens": 1}]})";
  const TakeReport report = ValidateTake(dir_);
  ASSERT_FALSE(report.ok());
  EXPECT_NE(report.problems[0].Text().find("rig.json"), std::string::npos);
  EXPECT_NE(report.problems[0].Text().find("lens"), std::string::npos);
}

TEST_F(ValidateTest, DuplicateCameraIdInRig) {
  geometry::Rig rig = testing::MakeRingRig(3, 40, 30);
  rig.cameras[2].model.id = "c0";
  std::ofstream(dir_ / "rig.json") << schema::RigToJson(rig);
  const TakeReport report = ValidateTake(dir_);
  ASSERT_FALSE(report.ok());
  EXPECT_NE(report.problems[0].Text().find("duplicate camera id 'c0'"), std::string::npos);
}

TEST_F(ValidateTest, MissingRigAndFrames) {
  fs::remove(dir_ / "rig.json");
  fs::remove_all(dir_ / "frames");
  const TakeReport report = ValidateTake(dir_);
  ASSERT_EQ(report.problems.size(), 2u);
  EXPECT_NE(report.problems[0].Text().find("rig.json: missing"), std::string::npos);
  EXPECT_NE(report.problems[1].Text().find("frames: missing"), std::string::npos);
}

TEST_F(ValidateTest, MissingFolder) {
  const TakeReport report = ValidateTake(dir_ / "nope");
  ASSERT_EQ(report.problems.size(), 1u);
  EXPECT_NE(report.problems[0].Text().find("no such directory"), std::string::npos);
}

TEST_F(ValidateTest, TruthForUnknownInstantAndWrongDepthKind) {
  fs::create_directories(dir_ / "truth/00-00-01-00/depth");
  std::ofstream(dir_ / "truth/00-00-01-00/mesh.ply") << "ply\n";
  cv::imwrite((dir_ / "truth/00-00-01-00/depth/c0.tiff").string(), cv::Mat(30, 40, CV_8UC1));
  const TakeReport report = ValidateTake(dir_);
  ASSERT_EQ(report.problems.size(), 3u) << report.Summary();  // c0 wrong kind, c1 and c2 missing
  EXPECT_NE(report.problems[0].Text().find("32-bit float"), std::string::npos) << report.Summary();
}

}  // namespace
}  // namespace dome::take
