#include "geometry/halcon.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "geometry_test_util.h"

namespace dome::geometry {
namespace {

using testing::DataDir;
using testing::ExpectInputError;
using testing::Replace;
using testing::ScratchDir;
using testing::TypicalCamera;
using testing::WriteFile;

const char* const kScenes[] = {"2016_10_24__17_43_02", "2016_10_24__17_44_40",
                               "2016_10_24__18_26_08", "2016_10_25__12_11_32"};

// Just enough of an ASCII PLY reader for reference.ply (a proper one lives in
// common/io): the vertex positions and their gray level (the red channel).
struct PlyPoints {
  std::vector<Eigen::Vector3d> positions;
  std::vector<double> gray;
};

PlyPoints ReadAsciiPlyVertices(const std::string& path) {
  PlyPoints points;
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "ply");
  size_t count = 0, vertex_count = 0;
  std::vector<std::string> properties;
  bool in_vertex = false;
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream words(line);
    std::string word, type, name;
    words >> word;
    if (word == "format") {
      words >> type;
      EXPECT_EQ(type, "ascii");
    } else if (word == "element") {
      words >> name >> count;
      in_vertex = name == "vertex";
      if (!in_vertex) {
        EXPECT_EQ(count, 0u) << "only vertices expected";
      }
      if (in_vertex) {
        properties.clear();
        vertex_count = count;
      }
    } else if (word == "property" && in_vertex) {
      words >> type >> name;
      properties.push_back(name);
    }
  }
  const auto index = [&](const std::string& name) {
    for (size_t i = 0; i < properties.size(); ++i) {
      if (properties[i] == name) {
        return static_cast<int>(i);
      }
    }
    ADD_FAILURE() << path << " has no vertex property " << name;
    return 0;
  };
  const int ix = index("x"), iy = index("y"), iz = index("z"), ired = index("red");
  std::vector<double> values(properties.size());
  for (size_t v = 0; v < vertex_count && std::getline(in, line); ++v) {
    std::istringstream words(line);
    for (double& value : values) {
      words >> value;
    }
    points.positions.emplace_back(values[ix], values[iy], values[iz]);
    points.gray.push_back(values[ired]);
  }
  EXPECT_EQ(points.positions.size(), vertex_count) << path;
  return points;
}

struct ProjectionStats {
  double valid_fraction = 0.0;  // in front, inside the image, on an alpha = 255 pixel
  double correlation = 0.0;     // image gray vs point gray, over the valid points
};

// Projects the reference points (metres -> mm) and samples the RGBA image.
ProjectionStats ProjectReference(const TsaiCamera& camera, const PlyPoints& points,
                                 const cv::Mat& rgba) {
  int valid = 0;
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  for (size_t i = 0; i < points.positions.size(); ++i) {
    Eigen::Vector2d pixel;
    if (!camera.Project(points.positions[i] * 1000.0, &pixel)) {
      continue;
    }
    const long col = std::lround(pixel.x()), row = std::lround(pixel.y());
    if (col < 0 || row < 0 || col >= rgba.cols || row >= rgba.rows) {
      continue;
    }
    const cv::Vec4b value = rgba.at<cv::Vec4b>(static_cast<int>(row), static_cast<int>(col));
    if (value[3] != 255) {
      continue;
    }
    ++valid;
    const double a = value[0], b = points.gray[i];
    sa += a;
    sb += b;
    saa += a * a;
    sbb += b * b;
    sab += a * b;
  }
  ProjectionStats stats;
  stats.valid_fraction = static_cast<double>(valid) / points.positions.size();
  if (valid > 2) {
    const double n = valid;
    const double cov = sab / n - (sa / n) * (sb / n);
    const double var_a = saa / n - (sa / n) * (sa / n), var_b = sbb / n - (sb / n) * (sb / n);
    stats.correlation = var_a > 0 && var_b > 0 ? cov / std::sqrt(var_a * var_b) : 0.0;
  }
  return stats;
}

// What the pose test demands: nearly every reference point lands in front of the
// camera, inside the image, on valid pixels, and the gray levels it lands on follow
// the points' own colours (which PMVS took from these images). The colour test is
// what rejects a flipped pose for camera07, whose rotation is nearly its own inverse.
bool PoseLooksRight(const ProjectionStats& stats) {
  return stats.valid_fraction >= 0.99 && stats.correlation >= 0.2;
}

std::string CameraFile(const std::string& scene, const char* kind, int n) {
  char name[64];
  std::snprintf(name, sizeof(name), "/%s_camera%02d", kind, n);
  return DataDir() + "/robovision/" + scene + name;
}

TEST(Halcon, ReferencePointsLandOnTheObjectInEveryCamera) {
  DOME_SKIP_WITHOUT(DataDir() + "/robovision");
  double min_valid = 1.0, min_correlation = 1.0, max_flipped_correlation = -1.0;
  for (const char* scene : kScenes) {
    const PlyPoints points =
        ReadAsciiPlyVertices(DataDir() + "/robovision/" + scene + "/reference.ply");
    ASSERT_GT(points.positions.size(), 10000u);
    for (int n = 1; n <= 12; ++n) {
      SCOPED_TRACE(std::string(scene) + " camera " + std::to_string(n));
      const TsaiCamera camera = ReadHalconCamera(CameraFile(scene, "intrinsics", n) + ".txt",
                                                 CameraFile(scene, "extrinsics", n) + ".txt",
                                                 "camera" + std::to_string(n));
      const cv::Mat rgba = cv::imread(CameraFile(scene, "image", n) + ".png", cv::IMREAD_UNCHANGED);
      ASSERT_EQ(rgba.type(), CV_8UC4);
      ASSERT_EQ(rgba.cols, camera.width_px);
      ASSERT_EQ(rgba.rows, camera.height_px);

      const ProjectionStats stats = ProjectReference(camera, points, rgba);
      EXPECT_TRUE(PoseLooksRight(stats))
          << "valid " << stats.valid_fraction << ", correlation " << stats.correlation;
      min_valid = std::min(min_valid, stats.valid_fraction);
      min_correlation = std::min(min_correlation, stats.correlation);

      // The test has teeth: the file read the other way (world -> camera) fails it.
      TsaiCamera flipped = camera;
      flipped.rotation = camera.rotation.transpose();
      flipped.translation_mm = camera.CentreWorld();
      const ProjectionStats wrong = ProjectReference(flipped, points, rgba);
      EXPECT_FALSE(PoseLooksRight(wrong))
          << "flipped: valid " << wrong.valid_fraction << ", correlation " << wrong.correlation;
      if (wrong.valid_fraction > 0.5) {
        max_flipped_correlation = std::max(max_flipped_correlation, wrong.correlation);
      }
      // And so do metres taken for millimetres.
      TsaiCamera metres = camera;
      metres.translation_mm /= 1000.0;
      EXPECT_FALSE(PoseLooksRight(ProjectReference(metres, points, rgba)));
    }
  }
  std::printf(
      "Robovision, 4 scenes x 12 cameras: min valid fraction %.4f, min correlation %.3f; "
      "flipped pose: max correlation where valid %.3f\n",
      min_valid, min_correlation, max_flipped_correlation);
}

TEST(Halcon, ReadsTheFieldsInMillimetres) {
  const std::string scene = DataDir() + "/robovision/2016_10_24__17_43_02";
  DOME_SKIP_WITHOUT(scene);
  const TsaiCamera camera = ReadHalconCamera(scene + "/intrinsics_camera01.txt",
                                             scene + "/extrinsics_camera01.txt", "cam01");
  EXPECT_EQ(camera.id, "cam01");
  EXPECT_EQ(camera.width_px, 1280);
  EXPECT_EQ(camera.height_px, 1024);
  EXPECT_NEAR(camera.focal_mm, 17.7071077277789, 1e-12);
  EXPECT_NEAR(camera.sensor.dx_mm, 5.32860915073091e-3, 1e-15);
  EXPECT_NEAR(camera.sensor.dy_mm, 5.3343238963673e-3, 1e-15);
  EXPECT_EQ(camera.cx_px, 663.241838169111);
  EXPECT_EQ(camera.cy_px, 490.446629408713);
  EXPECT_EQ(camera.sx, 1.0);
  EXPECT_EQ(camera.kappa1_per_mm2, 0.0);
  // fx = Focus / Sx = 0.0177071077277789 / 5.32860915073091e-06 = 3323.03 px.
  EXPECT_NEAR(camera.K()(0, 0), 0.0177071077277789 / 5.32860915073091e-06, 1e-9);
  // The file's t (-0.000545, -0.000521, -0.179648) m is the camera centre.
  EXPECT_LT((camera.CentreWorld() - Eigen::Vector3d(-0.545, -0.521, -179.648)).norm(), 1e-9);
  // Its optical axis (third column of the file's R) points at the object near the origin.
  const Eigen::Vector3d axis = camera.rotation.row(2).transpose();
  EXPECT_NEAR(axis.z(), 0.999533, 1e-5);
}

const std::string kIntrinsics = R"(#
# INTERNAL CAMERA PARAMETERS
#
ParGroup: Camera: Parameter;
	"Internal camera parameters";

Focus:foc:	0.016;
	DOUBLE:0.0:;
	"Focal length of the lens";

Poly1:poly1:	0;
	DOUBLE::;
	"1st polynomial distortion coefficient";

Poly2:poly2:	0;
	DOUBLE::;
	"2nd";

Poly3:poly3:	0;
	DOUBLE::;
	"3rd";

Poly4:poly4:	0;
	DOUBLE::;
	"4th";

Poly5:poly5:	0;
	DOUBLE::;
	"5th";

Sx:sx:	5e-06;
	DOUBLE:0.0:;
	"Width of a cell on the sensor";

Sy:sy:	5.5e-06;
	DOUBLE:0.0:;
	"Height of a cell on the sensor";

Cx:cx:	640.5;
	DOUBLE::;
	"X-coordinate of the image center";

Cy:cy:	511.25;
	DOUBLE::;
	"Y-coordinate of the image center";

ImageWidth:imgw:	1280;
	INT:1:32768;
	"Width of the images";

ImageHeight:imgh:	1024;
	INT:1:32768;
	"Height of the images";
)";

// Camera -> world: 90 degrees about z, camera centre at (0.1, 0.2, -0.3) m.
const std::string kExtrinsics = "0 -1 0 0.1 1 0 0 0.2 0 0 1 -0.3 ";

TEST(Halcon, HandWrittenFilesMapAsDocumented) {
  ScratchDir dir;
  WriteFile(dir.File("in.txt"), kIntrinsics);
  WriteFile(dir.File("ex.txt"), kExtrinsics + "#\n");
  const TsaiCamera camera = ReadHalconCamera(dir.File("in.txt"), dir.File("ex.txt"), "c");
  // focal 16 mm, cells 5 x 5.5 um -> fx = 16 / 0.005 = 3200, fy = 16 / 0.0055 = 2909.09.
  EXPECT_NEAR(camera.K()(0, 0), 3200.0, 1e-9);
  EXPECT_NEAR(camera.K()(1, 1), 16.0 / 0.0055, 1e-9);
  EXPECT_EQ(camera.cx_px, 640.5);
  EXPECT_EQ(camera.cy_px, 511.25);
  // World point 1 m in front of the camera along its axis: centre + R_cw * (0, 0, 1000).
  // R_cw's third column is (0, 0, 1): the point (100, 200, 700) mm -> principal point.
  Eigen::Vector2d pixel;
  ASSERT_TRUE(camera.Project(Eigen::Vector3d(100, 200, 700), &pixel));
  EXPECT_LT((pixel - Eigen::Vector2d(640.5, 511.25)).norm(), 1e-9);
  // Camera x axis = R_cw's first column = world +y: world (100, 210, 700) is 10 mm right
  // at 1000 mm depth -> u = 16 * 10 / 1000 mm / 0.005 mm = 32 px.
  ASSERT_TRUE(camera.Project(Eigen::Vector3d(100, 210, 700), &pixel));
  EXPECT_LT((pixel - Eigen::Vector2d(640.5 + 32.0, 511.25)).norm(), 1e-9);
}

TEST(Halcon, WriteReadRoundTrip) {
  ScratchDir dir;
  TsaiCamera camera = TypicalCamera(0.0);
  WriteHalconIntrinsics(dir.File("in.txt"), camera);
  WriteHalconExtrinsics(dir.File("ex.txt"), camera);
  const TsaiCamera back = ReadHalconCamera(dir.File("in.txt"), dir.File("ex.txt"), camera.id);
  // sx and ncx / nfx fold into the cell width: the same K, not the same fields.
  EXPECT_LT((back.K() - camera.K()).cwiseAbs().maxCoeff(), 1e-9 * camera.K()(0, 0));
  EXPECT_EQ(back.width_px, camera.width_px);
  EXPECT_EQ(back.height_px, camera.height_px);
  EXPECT_NEAR(back.focal_mm, camera.focal_mm, 1e-12);
  EXPECT_LT((back.rotation - camera.rotation).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((back.translation_mm - camera.translation_mm).norm(),
            1e-9 * camera.translation_mm.norm());
  for (const Eigen::Vector3d& world :
       {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1000, 2000, 500)}) {
    Eigen::Vector2d a, b;
    ASSERT_EQ(camera.Project(world, &a), back.Project(world, &b));
    EXPECT_LT((a - b).norm(), 1e-9 * a.norm());
  }
  // A camera with sx = 1 and ncx = nfx comes back field for field.
  camera.sx = 1.0;
  camera.sensor.ncx = camera.sensor.nfx = camera.width_px;
  WriteHalconIntrinsics(dir.File("in.txt"), camera);
  const TsaiCamera same = ReadHalconIntrinsics(dir.File("in.txt"), "x");
  EXPECT_NEAR(same.sensor.dx_mm, camera.sensor.dx_mm, 1e-18);
  EXPECT_NEAR(same.sensor.dy_mm, camera.sensor.dy_mm, 1e-18);
  EXPECT_EQ(same.cx_px, camera.cx_px);
  EXPECT_EQ(same.cy_px, camera.cy_px);
}

TEST(Halcon, BadIntrinsics) {
  ScratchDir dir;
  const std::string path = dir.File("in.txt");
  ExpectInputError([] { ReadHalconIntrinsics("/nonexistent/in.txt", "c"); },
                   {"/nonexistent/in.txt", "cannot open"});
  const auto expect = [&](const std::string& from, const std::string& to,
                          std::initializer_list<std::string> fragments) {
    WriteFile(path, Replace(kIntrinsics, from, to));
    ExpectInputError([&] { ReadHalconIntrinsics(path, "c"); }, fragments);
  };
  for (const char* name : {"Focus:foc:\t0.016;", "Sx:sx:\t5e-06;", "Sy:sy:\t5.5e-06;",
                           "Cx:cx:\t640.5;", "Cy:cy:\t511.25;", "ImageWidth:imgw:\t1280;",
                           "ImageHeight:imgh:\t1024;", "Poly3:poly3:\t0;"}) {
    const std::string parameter = std::string(name).substr(0, std::string(name).find(':'));
    const std::string where = std::string(path).append(": ").append(parameter);
    expect(name, "", {where, "missing parameter"});
    expect(name, std::string(parameter).append(":x:\tnan;"), {where, "nan"});
  }
  expect("Poly1:poly1:\t0;", "Poly1:poly1:\t-512.3;", {path + ": Poly1", "-512.3", "not Tsai"});
  expect("Poly5:poly5:\t0;", "Poly5:poly5:\t1e-3;", {path + ": Poly5", "not Tsai"});
  expect("Focus:foc:\t0.016;", "Focus:foc:\t0;", {path + ": Focus", "telecentric"});
  expect("Sx:sx:\t5e-06;", "Sx:sx:\t-5e-06;", {path + ": Sx", "positive"});
  expect("ImageWidth:imgw:\t1280;", "ImageWidth:imgw:\t12.5;", {path + ": ImageWidth", "integer"});
  expect("ImageHeight:imgh:\t1024;", "ImageHeight:imgh:\t0;", {path + ": ImageHeight", "positive"});
  expect("Cx:cx:\t640.5;", "Cx:cx:\t640.5", {path + ": Cx", "Name:shortname:value;"});
  expect("Cy:cy:\t511.25;", "Cy:cy:\t511.25;\nCy:cy:\t1;", {path + ": Cy", "twice"});
  // The division model: Kappa instead of Poly1..5, accepted only when zero.
  std::string division = kIntrinsics;
  for (const char* poly : {"Poly1:poly1:\t0;", "Poly2:poly2:\t0;", "Poly3:poly3:\t0;",
                           "Poly4:poly4:\t0;", "Poly5:poly5:\t0;"}) {
    division = Replace(division, poly, "");
  }
  WriteFile(path, Replace(division, "Focus:foc:", "Kappa:kappa:\t0;\nFocus:foc:"));
  EXPECT_NO_THROW(ReadHalconIntrinsics(path, "c"));
  WriteFile(path, Replace(division, "Focus:foc:", "Kappa:kappa:\t-1200;\nFocus:foc:"));
  ExpectInputError([&] { ReadHalconIntrinsics(path, "c"); }, {path + ": Kappa", "not Tsai"});
  WriteFile(path, division);
  ExpectInputError([&] { ReadHalconIntrinsics(path, "c"); }, {path + ": Poly1", "Kappa"});
}

TEST(Halcon, BadExtrinsics) {
  ScratchDir dir;
  const std::string path = dir.File("ex.txt");
  Eigen::Matrix3d r;
  Eigen::Vector3d t;
  ExpectInputError([&] { ReadHalconExtrinsics("/nonexistent/ex.txt", &r, &t); },
                   {"/nonexistent/ex.txt", "cannot open"});
  const auto expect = [&](const std::string& text, std::initializer_list<std::string> fragments) {
    WriteFile(path, text);
    ExpectInputError([&] { ReadHalconExtrinsics(path, &r, &t); }, fragments);
  };
  expect("0 -1 0 0.1 1 0 0 0.2 0 0 1", {path, "expected 12 numbers", "got 11"});
  expect(kExtrinsics + " 7", {path, "expected 12 numbers", "got 13"});
  expect("", {path, "got 0"});
  expect("0 -1 0 0.1 1 0 0 0.2 0 0 1 abc", {path + ": number 12 (row 3, column 4)", "abc"});
  expect("0 -1 0 0.1 1 0 nan 0.2 0 0 1 -0.3", {path + ": number 7", "nan"});
  expect("0 -1 0 0.1 1 0.01 0 0.2 0 0 1 -0.3", {path + ": R", "not orthonormal"});
  expect("0 -1 0 0.1 1 0 0 0.2 0 0 -1 -0.3", {path + ": R", "determinant"});
  // A trailing '#' comment and 6-decimal rounding are fine.
  WriteFile(path, "0.000001 -1 0 0.1 1 0 0 0.2 0 0 1 -0.3 # pose\n");
  EXPECT_NO_THROW(ReadHalconExtrinsics(path, &r, &t));
  EXPECT_LT((r * r.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-15);
}

TEST(Halcon, WritersRejectWhatTheFormatCannotHold) {
  ScratchDir dir;
  ExpectInputError([&] { WriteHalconIntrinsics(dir.File("in.txt"), TypicalCamera(1e-4)); },
                   {dir.File("in.txt"), "camera 'typical'", "kappa1"});
  TsaiCamera bad = TypicalCamera(0.0);
  bad.rotation(0, 0) = 5;
  ExpectInputError([&] { WriteHalconExtrinsics(dir.File("ex.txt"), bad); },
                   {dir.File("ex.txt"), "rotation"});
}

}  // namespace
}  // namespace dome::geometry
