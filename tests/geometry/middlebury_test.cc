#include "geometry/middlebury.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "geometry_test_util.h"

namespace dome::geometry {
namespace {

using testing::DataDir;
using testing::ExpectInputError;
using testing::ScratchDir;
using testing::TypicalCamera;
using testing::WriteFile;

MiddleburyReadOptions TempleOptions() {
  MiddleburyReadOptions options;
  options.width_px = 640;
  options.height_px = 480;
  return options;
}

// The 8 corners of the templeSparseRing README's tight bounding box, in mm.
std::vector<Eigen::Vector3d> BoundingBoxCornersMm() {
  const Eigen::Vector3d lo(-0.073568, 0.021728, -0.012445), hi(0.028855, 0.181892, 0.062736);
  std::vector<Eigen::Vector3d> corners;
  corners.reserve(8);
  for (int i = 0; i < 8; ++i) {
    corners.emplace_back(1000.0 * (i & 1 ? hi.x() : lo.x()), 1000.0 * (i & 2 ? hi.y() : lo.y()),
                         1000.0 * (i & 4 ? hi.z() : lo.z()));
  }
  return corners;
}

bool AllCornersInside(const TsaiCamera& camera) {
  for (const Eigen::Vector3d& corner : BoundingBoxCornersMm()) {
    Eigen::Vector2d pixel;
    if (!camera.Project(corner, &pixel)) {
      return false;
    }
    if (pixel.x() < -0.5 || pixel.y() < -0.5 || pixel.x() > camera.width_px - 0.5 ||
        pixel.y() > camera.height_px - 0.5) {
      return false;
    }
  }
  return true;
}

TEST(Middlebury, TempleBoundingBoxIsSeenByEveryCamera) {
  const std::string folder = DataDir() + "/middlebury-mv/templeSparseRing";
  DOME_SKIP_WITHOUT(folder);
  const std::vector<TsaiCamera> cameras =
      ReadMiddleburyPar(folder + "/templeSR_par.txt", TempleOptions());
  ASSERT_EQ(cameras.size(), 16u);
  EXPECT_EQ(cameras[0].id, "templeSR0001.png");
  EXPECT_EQ(cameras[15].id, "templeSR0016.png");
  for (const TsaiCamera& camera : cameras) {
    SCOPED_TRACE(camera.id);
    EXPECT_TRUE(AllCornersInside(camera));
    for (const Eigen::Vector3d& corner : BoundingBoxCornersMm()) {
      EXPECT_GT(camera.WorldToCamera(corner).z(), 0.0);
    }
    // The test has teeth: the same numbers read as camera -> world fail it.
    TsaiCamera flipped = camera;
    flipped.rotation = camera.rotation.transpose();
    flipped.translation_mm = camera.CentreWorld();
    EXPECT_FALSE(AllCornersInside(flipped));
  }
  // Hand check of the first line: K = [1520.4 0 302.32; 0 1525.9 246.87; 0 0 1],
  // t = (-0.0726637729648, 0.0223360353405, 0.614604845959) m.
  const Eigen::Matrix3d k = cameras[0].K();
  EXPECT_NEAR(k(0, 0), 1520.4, 1e-9);
  EXPECT_NEAR(k(1, 1), 1525.9, 1e-9);
  EXPECT_NEAR(k(0, 2), 302.32, 1e-12);
  EXPECT_NEAR(k(1, 2), 246.87, 1e-12);
  EXPECT_LT(
      (cameras[0].translation_mm - Eigen::Vector3d(-72.6637729648, 22.3360353405, 614.604845959))
          .norm(),
      1e-9);
  EXPECT_NEAR(cameras[0].rotation(0, 1), 0.98329680886213122, 1e-9);
}

TEST(Middlebury, WriteReadRoundTrip) {
  ScratchDir dir;
  std::vector<TsaiCamera> cameras;
  for (int i = 0; i < 3; ++i) {
    TsaiCamera camera = TypicalCamera(0.0);
    camera.id = "view" + std::to_string(i) + ".png";
    camera.rotation = RotationFromTsaiAngles(0.3 * i, -0.2, 1.0 + i);
    camera.translation_mm.x() += 100.0 * i;
    cameras.push_back(camera);
  }
  WriteMiddleburyPar(dir.File("par.txt"), cameras);
  MiddleburyReadOptions options;
  options.width_px = 720;
  options.height_px = 576;
  const std::vector<TsaiCamera> back = ReadMiddleburyPar(dir.File("par.txt"), options);
  ASSERT_EQ(back.size(), cameras.size());
  for (size_t i = 0; i < back.size(); ++i) {
    EXPECT_EQ(back[i].id, cameras[i].id);
    EXPECT_LT((back[i].K() - cameras[i].K()).cwiseAbs().maxCoeff(), 1e-9 * cameras[i].K()(0, 0));
    EXPECT_LT((back[i].rotation - cameras[i].rotation).cwiseAbs().maxCoeff(), 1e-14);
    EXPECT_LT((back[i].translation_mm - cameras[i].translation_mm).norm(),
              1e-9 * cameras[i].translation_mm.norm());
  }
  // Other units: the file in centimetres.
  WriteMiddleburyPar(dir.File("par_cm.txt"), cameras, 10.0);
  options.mm_per_unit = 10.0;
  const std::vector<TsaiCamera> cm = ReadMiddleburyPar(dir.File("par_cm.txt"), options);
  EXPECT_LT((cm[1].translation_mm - cameras[1].translation_mm).norm(),
            1e-9 * cameras[1].translation_mm.norm());
}

const char* const kLine =
    "a.png 1520.4 0 302.32 0 1525.9 246.87 0 0 1 "
    "1 0 0 0 1 0 0 0 1 0.01 0.02 0.6";

TEST(Middlebury, BadInput) {
  ScratchDir dir;
  const std::string path = dir.File("par.txt");
  ExpectInputError([] { ReadMiddleburyPar("/nonexistent/par.txt", TempleOptions()); },
                   {"/nonexistent/par.txt", "cannot open"});
  MiddleburyReadOptions no_size;
  ExpectInputError([&] { ReadMiddleburyPar(path, no_size); },
                   {"MiddleburyReadOptions.width_px", "image size"});
  MiddleburyReadOptions bad_unit = TempleOptions();
  bad_unit.mm_per_unit = -1;
  ExpectInputError([&] { ReadMiddleburyPar(path, bad_unit); },
                   {"MiddleburyReadOptions.mm_per_unit"});

  const auto expect = [&](const std::string& text, std::initializer_list<std::string> fragments) {
    WriteFile(path, text);
    ExpectInputError([&] { ReadMiddleburyPar(path, TempleOptions()); }, fragments);
  };
  const std::string line = kLine;
  WriteFile(path, "1\n" + line + "\n");
  EXPECT_NO_THROW(ReadMiddleburyPar(path, TempleOptions()));
  expect("", {path, "empty"});
  expect("x\n" + line, {path + ": line 1 (image count)", "integer"});
  expect("2\n" + line + "\n", {path, "announces 2", "only 1"});
  expect("1\n" + line + "\n" + line + "\n", {path + ": line 3", "more"});
  expect("1\na.png 1 2 3\n", {path + ": line 2", "22 fields", "got 4"});
  expect("1\n" + line + " 7\n", {path + ": line 2", "got 23"});
  expect("1\n" + std::string(kLine).replace(line.find("0.02"), 4, "nan"),
         {path + ": line 2 (a.png): t2", "nan"});
  expect("1\n" + std::string(kLine).replace(line.find("302.32"), 6, "zz"),
         {path + ": line 2 (a.png): k13", "zz"});
  expect("1\n" + std::string(kLine).replace(line.find(" 0 302.32"), 2, " 3"),
         {path + ": line 2 (a.png): K(0,1) (skew)", "zero"});
  expect("1\n" + std::string(kLine).replace(line.find("1520.4"), 6, "-1520"),
         {path + ": line 2 (a.png): K(0,0) (fx)", "positive"});
  expect("1\n" + std::string(kLine).replace(line.find(" 1 0 0 0 1"), 2, " 2"),
         {path + ": line 2 (a.png): r11..r33", "orthonormal"});
  expect("1\n" + std::string(kLine).replace(line.find(" 1 0.01"), 2, " -1"),
         {path + ": line 2 (a.png): r11..r33", "determinant"});
  expect("2\n" + line + "\n" + line + "\n", {path + ": line 3 (a.png)", "twice"});
}

TEST(Middlebury, WriterRejectsWhatTheFormatCannotHold) {
  ScratchDir dir;
  const std::string path = dir.File("par.txt");
  TsaiCamera distorted = TypicalCamera(1e-4);
  ExpectInputError([&] { WriteMiddleburyPar(path, {distorted}); },
                   {path + ": camera 'typical'", "distortion"});
  TsaiCamera spaced = TypicalCamera(0.0);
  spaced.id = "a b.png";
  ExpectInputError([&] { WriteMiddleburyPar(path, {spaced}); }, {path, "white space"});
  TsaiCamera nan_focal = TypicalCamera(0.0);
  nan_focal.focal_mm = std::nan("");
  ExpectInputError([&] { WriteMiddleburyPar(path, {nan_focal}); }, {path, "focal_mm"});
  ExpectInputError(
      [&] {
        WriteMiddleburyPar(path, {TypicalCamera(0.0), TypicalCamera(0.0)});
      },
      {path, "twice"});
}

}  // namespace
}  // namespace dome::geometry
