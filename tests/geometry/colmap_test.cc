#include "geometry/colmap.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <string>
#include <vector>

#include "geometry_test_util.h"

namespace dome::geometry {
namespace {

using testing::ExpectInputError;
using testing::ScratchDir;
using testing::TypicalCamera;
using testing::WriteFile;

const std::string kCameras =
    "# Camera list with one line of data per camera:\n"
    "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
    "1 PINHOLE 640 480 500 510 320.5 240.5\n"
    "2 SIMPLE_RADIAL 640 480 520 318 242 -0.12\n"
    "3 RADIAL 640 480 520 318 242 -0.1 0.02\n"
    "4 SIMPLE_PINHOLE 640 480 500 320 240\n"
    "5 OPENCV 640 480 500 505 320 240 0.05 0 0 0\n";

// Image 1: identity rotation, t = (0, 0, 2) units. Image 2: 90 degrees about z
// (qw = qz = sqrt(1/2)), camera 2, with a POINTS2D line.
const std::string kImages =
    "# Image list with two lines of data per image:\n"
    "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
    "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
    "1 1 0 0 0 0 0 2 1 first.jpg\n"
    "\n"
    "2 0.70710678118654757 0 0 0.70710678118654757 0.1 0 2 2 second.jpg\n"
    "10.5 20.25 -1 30 40 17\n"
    "3 1 0 0 0 0 0 2 3 third.jpg\n"
    "\n"
    "4 1 0 0 0 0 0 2 4 fourth.jpg\n"
    "\n"
    "5 1 0 0 0 0 0 2 5 fifth.jpg\n"
    "\n";

ColmapReadOptions Options(double mm_per_unit) {
  ColmapReadOptions options;
  options.mm_per_unit = mm_per_unit;
  return options;
}

std::vector<ColmapImage> ReadModel(const ScratchDir& dir, const std::string& cameras,
                                   const std::string& images, double mm_per_unit = 100.0) {
  WriteFile(dir.File("cameras.txt"), cameras);
  WriteFile(dir.File("images.txt"), images);
  return ReadColmapModel(dir.path(), Options(mm_per_unit));
}

TEST(Colmap, HandWrittenModel) {
  ScratchDir dir;
  const std::vector<ColmapImage> images = ReadModel(dir, kCameras, kImages);
  ASSERT_EQ(images.size(), 5u);
  const ColmapImage& first = images[0];
  EXPECT_EQ(first.image_id, 1);
  EXPECT_EQ(first.camera_id, 1);
  EXPECT_EQ(first.name, "first.jpg");
  EXPECT_EQ(first.camera.id, "first.jpg");
  EXPECT_EQ(first.num_points2d, 0);
  EXPECT_TRUE(first.distortion_fit.exact);
  // COLMAP's principal point (320.5, 240.5) is dome's (320, 240): the 0.5 px shift.
  EXPECT_EQ(first.camera.cx_px, 320.0);
  EXPECT_EQ(first.camera.cy_px, 240.0);
  // t = (0, 0, 2) units at 100 mm per unit.
  EXPECT_EQ(first.camera.translation_mm, Eigen::Vector3d(0, 0, 200));
  // World origin: on the axis, at COLMAP's (320.5, 240.5) = dome's (320, 240).
  Eigen::Vector2d pixel;
  ASSERT_TRUE(first.camera.Project(Eigen::Vector3d(0, 0, 0), &pixel));
  EXPECT_LT((pixel - Eigen::Vector2d(320.0, 240.0)).norm(), 1e-12);
  // (20, 10, 0) mm -> camera (20, 10, 200): x = 500 * 0.1 + 320 = 370,
  // y = 510 * 0.05 + 240 = 265.5 (COLMAP would say 370.5, 266).
  ASSERT_TRUE(first.camera.Project(Eigen::Vector3d(20, 10, 0), &pixel));
  EXPECT_LT((pixel - Eigen::Vector2d(370.0, 265.5)).norm(), 1e-9);

  // 90 degrees about z: R = [0 -1 0; 1 0 0; 0 0 1].
  const ColmapImage& second = images[1];
  Eigen::Matrix3d expected;
  expected << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  EXPECT_LT((second.camera.rotation - expected).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(second.camera.translation_mm, Eigen::Vector3d(10, 0, 200));
  EXPECT_EQ(second.num_points2d, 2);
  EXPECT_FALSE(second.distortion_fit.exact);
  EXPECT_EQ(second.camera.cx_px, 317.5);
  EXPECT_EQ(second.camera.sx, 1.0);
  // SIMPLE_PINHOLE: fx = fy = f.
  EXPECT_NEAR(images[3].camera.K()(0, 0), 500.0, 1e-9);
  EXPECT_NEAR(images[3].camera.K()(1, 1), 500.0, 1e-9);
  // OPENCV with p1 = p2 = 0.
  EXPECT_NEAR(images[4].camera.K()(1, 1), 505.0, 1e-9);
  EXPECT_GT(images[4].camera.kappa1_per_mm2, -1.0);
  EXPECT_LT(images[4].camera.kappa1_per_mm2, 0.0);  // k1 > 0 is kappa1 < 0
}

// Largest distance over the image between the Tsai camera's pixel and OpenCV's (the
// COLMAP model's) pixel of the same ray; COLMAP's pixels shifted to dome's convention.
double MaxDisagreementPx(const TsaiCamera& tsai, double fx, double fy, double cx_colmap,
                         double cy_colmap, double k1, double k2) {
  std::vector<cv::Point3d> rays;
  std::vector<Eigen::Vector2d> pixels;
  for (int j = 0; j <= 30; ++j) {
    for (int i = 0; i <= 30; ++i) {
      const Eigen::Vector2d pixel((tsai.width_px - 1) * i / 30.0, (tsai.height_px - 1) * j / 30.0);
      const Eigen::Vector3d ray = tsai.rotation * tsai.BackProject(pixel);
      rays.emplace_back(ray.x(), ray.y(), ray.z());
      pixels.push_back(pixel);
    }
  }
  const cv::Matx33d k(fx, 0, cx_colmap - 0.5, 0, fy, cy_colmap - 0.5, 0, 0, 1);
  std::vector<cv::Point2d> projected;
  cv::projectPoints(rays, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k,
                    std::vector<double>{k1, k2, 0, 0}, projected);
  double worst = 0.0;
  for (size_t i = 0; i < rays.size(); ++i) {
    worst =
        std::max(worst, std::hypot(projected[i].x - pixels[i].x(), projected[i].y - pixels[i].y()));
  }
  return worst;
}

TEST(Colmap, RadialModelsAreFittedAndReported) {
  ScratchDir dir;
  const std::vector<ColmapImage> images = ReadModel(dir, kCameras, kImages);
  // SIMPLE_RADIAL k = -0.12 and RADIAL k1 = -0.1, k2 = 0.02: the Tsai camera agrees with
  // COLMAP's model about where each ray lands to within the reported residual.
  const ColmapImage& simple = images[1];
  const double simple_error = MaxDisagreementPx(simple.camera, 520, 520, 318, 242, -0.12, 0.0);
  EXPECT_LT(simple_error, 1.5 * simple.distortion_fit.max_residual_px + 1e-6);
  // k = -0.12 at f = 520 px moves the corners by ~28 px; one Tsai kappa1 follows it to
  // ~3 px there (rms 0.45 px): a real limit of the conversion, which is why it is
  // reported. Far better than no distortion at all:
  EXPECT_LT(simple_error, 0.2 * MaxDisagreementPx(simple.camera, 520, 520, 318, 242, 0.0, 0.0));
  const ColmapImage& radial = images[2];
  const double radial_error = MaxDisagreementPx(radial.camera, 520, 520, 318, 242, -0.1, 0.02);
  EXPECT_LT(radial_error, 1.5 * radial.distortion_fit.max_residual_px + 1e-6);
  // k2 matters: ignoring it would be worse than the fit that includes it.
  EXPECT_GT(MaxDisagreementPx(radial.camera, 520, 520, 318, 242, -0.1, 0.0), radial_error);
  std::printf("COLMAP SIMPLE_RADIAL k=-0.12: %s; RADIAL -0.1, 0.02: %s\n",
              simple.distortion_fit.BriefReport().c_str(),
              radial.distortion_fit.BriefReport().c_str());
}

TEST(Colmap, WriteReadRoundTrip) {
  ScratchDir dir;
  std::vector<TsaiCamera> cameras;
  TsaiCamera a = TypicalCamera(0.0);  // fx != fy, no distortion -> PINHOLE
  a.id = "a.png";
  TsaiCamera b = TypicalCamera(4e-4);  // fx != fy with distortion -> OPENCV
  b.id = "b.png";
  b.rotation = RotationFromTsaiAngles(-2.0, 0.3, 2.9);  // a quaternion with qw < 0 first
  TsaiCamera c = TypicalCamera(-3e-4);  // square pixels with distortion -> SIMPLE_RADIAL
  c.id = "c.png";
  c.sx = 1.0;
  c.sensor = {720, 720, 0.023, 0.023};
  cameras = {a, b, c};
  ColmapWriteOptions write_options;
  write_options.mm_per_unit = 25.4;  // inches
  const std::vector<RadialFitReport> reports = WriteColmapModel(dir.path(), cameras, write_options);
  ASSERT_EQ(reports.size(), 3u);
  EXPECT_TRUE(reports[0].exact);
  EXPECT_FALSE(reports[1].exact);

  std::ifstream cameras_file(dir.File("cameras.txt"));
  const std::string text((std::istreambuf_iterator<char>(cameras_file)),
                         std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("1 PINHOLE 720 576"), std::string::npos) << text;
  EXPECT_NE(text.find("2 OPENCV 720 576"), std::string::npos) << text;
  EXPECT_NE(text.find("3 SIMPLE_RADIAL 720 576"), std::string::npos) << text;
  EXPECT_TRUE(std::ifstream(dir.File("points3D.txt")).good());

  const std::vector<ColmapImage> back = ReadColmapModel(dir.path(), Options(25.4));
  ASSERT_EQ(back.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    SCOPED_TRACE(cameras[i].id);
    EXPECT_EQ(back[i].name, cameras[i].id);
    EXPECT_EQ(back[i].image_id, static_cast<int>(i + 1));
    EXPECT_LT((back[i].camera.K() - cameras[i].K()).cwiseAbs().maxCoeff(),
              1e-9 * cameras[i].K()(0, 0));
    EXPECT_LT((back[i].camera.rotation - cameras[i].rotation).cwiseAbs().maxCoeff(), 1e-14);
    EXPECT_LT((back[i].camera.translation_mm - cameras[i].translation_mm).norm(),
              1e-9 * cameras[i].translation_mm.norm());
  }
  // Without distortion the camera comes back exactly: same pixels for the same points.
  for (const Eigen::Vector3d& world : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(500, 1500, 200)}) {
    Eigen::Vector2d p, q;
    ASSERT_EQ(cameras[0].Project(world, &p), back[0].camera.Project(world, &q));
    EXPECT_LT((p - q).norm(), 1e-9 * p.norm());
  }
  // With distortion, kappa1 survives the two fits approximately: every pixel moves by
  // less than the two reported residuals together.
  for (size_t i = 1; i < 3; ++i) {
    const double bound = reports[i].max_residual_px + back[i].distortion_fit.max_residual_px + 1e-6;
    for (double y = 0; y < 576; y += 25) {
      for (double x = 0; x < 720; x += 25) {
        const Eigen::Vector2d pixel(x, y);
        EXPECT_LT((back[i].camera.UndistortPixel(pixel) - cameras[i].UndistortPixel(pixel)).norm(),
                  2 * bound + 0.05);
      }
    }
  }
}

TEST(Colmap, BadInput) {
  ScratchDir dir;
  ExpectInputError([] { ReadColmapModel("/nonexistent", Options(1.0)); },
                   {"/nonexistent/cameras.txt", "cannot open"});
  ExpectInputError([&] { ReadModel(dir, kCameras, kImages, 0.0); },
                   {"ColmapReadOptions.mm_per_unit", "scale"});
  WriteFile(dir.File("cameras.txt"), kCameras);
  ExpectInputError(
      [&] { ReadColmapModelFiles(dir.File("cameras.txt"), dir.File("none.txt"), Options(1)); },
      {dir.File("none.txt"), "cannot open"});

  const std::string cameras_path = dir.File("cameras.txt");
  const std::string images_path = dir.File("images.txt");
  const auto cameras_error = [&](const std::string& line,
                                 std::initializer_list<std::string> fragments) {
    ExpectInputError([&] { ReadModel(dir, line, ""); }, fragments);
  };
  cameras_error("1 FISHEYE 640 480 500 320 240 0.1\n",
                {cameras_path + ": line 1 (camera 1): MODEL", "FISHEYE", "PINHOLE"});
  cameras_error("1 PINHOLE 640 480 500 510 320\n",
                {cameras_path + ": line 1 (camera 1)", "takes 4", "got 3"});
  cameras_error("1 PINHOLE 640 480 500 nan 320 240\n",
                {cameras_path + ": line 1 (camera 1): PINHOLE fy", "nan"});
  cameras_error("1 PINHOLE 640 abc 500 510 320 240\n",
                {cameras_path + ": line 1 (camera 1): HEIGHT"});
  cameras_error("x PINHOLE 640 480 500 510 320 240\n", {cameras_path + ": line 1: CAMERA_ID"});
  cameras_error("1 PINHOLE 640\n", {cameras_path + ": line 1", "got 3 fields"});
  cameras_error("1 OPENCV 640 480 500 505 320 240 0.05 0 0.001 0\n",
                {cameras_path + ": line 1 (camera 1): OPENCV p1", "tangential"});
  cameras_error("1 PINHOLE 640 480 -500 510 320 240\n",
                {cameras_path + ": line 1 (camera 1): K(0,0) (fx)"});
  cameras_error("1 PINHOLE 0 480 500 510 320 240\n",
                {cameras_path + ": line 1 (camera 1): width_px"});
  cameras_error("1 PINHOLE 640 480 500 510 320 240\n1 PINHOLE 640 480 500 510 320 240\n",
                {cameras_path + ": line 2 (camera 1): CAMERA_ID", "twice"});

  const std::string good_cameras = "1 PINHOLE 640 480 500 510 320.5 240.5\n";
  const auto images_error = [&](const std::string& text,
                                std::initializer_list<std::string> fragments) {
    ExpectInputError([&] { ReadModel(dir, good_cameras, text); }, fragments);
  };
  images_error("1 1 0 0 0 0 0 2 7 a.jpg\n\n",
               {images_path + ": line 1: CAMERA_ID", "camera 7 is not in"});
  images_error("1 2 0 0 0 0 0 2 1 a.jpg\n\n", {images_path + ": line 1: QW QX QY QZ", "norm"});
  images_error("1 0 0 0 0 0 0 2 1 a.jpg\n\n", {images_path + ": line 1: QW QX QY QZ", "norm"});
  images_error("1 1 0 0 0 0 nan 2 1 a.jpg\n\n", {images_path + ": line 1: TY", "nan"});
  images_error("1 1 0 0 zz 0 0 2 1 a.jpg\n\n", {images_path + ": line 1: QZ", "zz"});
  images_error("1 1 0 0 0 0 0 2 1\n\n", {images_path + ": line 1", "got 9 fields"});
  images_error("1 1 0 0 0 0 0 2 1 a.jpg\n1 2 3 4\n", {images_path + ": line 2", "triples"});
  images_error("1 1 0 0 0 0 0 2 1 a.jpg\n1 2 x\n",
               {images_path + ": line 2: POINTS2D[0].POINT3D_ID", "x"});
  images_error("1 1 0 0 0 0 0 2 1 a.jpg\n1 y 3\n", {images_path + ": line 2: POINTS2D[0].Y"});
  images_error("1 1 0 0 0 0 0 2 1 a.jpg\n\n1 1 0 0 0 0 0 2 1 b.jpg\n\n",
               {images_path + ": line 3: IMAGE_ID", "twice"});
  // An image line without its POINTS2D line: the next image line is taken for it.
  images_error("1 1 0 0 0 0 0 2 1 a.jpg\n2 1 0 0 0 0 0 2 1 b.jpg\n",
               {images_path + ": line 2", "triples"});
  // A last image without a POINTS2D line at the end of the file is accepted.
  EXPECT_EQ(ReadModel(dir, good_cameras, "1 1 0 0 0 0 0 2 1 a.jpg").size(), 1u);
}

TEST(Colmap, WriterRejectsUnusableCameras) {
  ScratchDir dir;
  ColmapWriteOptions options;
  TsaiCamera spaced = TypicalCamera(0.0);
  spaced.id = "my image.png";
  ExpectInputError([&] { WriteColmapModel(dir.path(), {spaced}, options); },
                   {"images.txt", "white space"});
  TsaiCamera bad = TypicalCamera(0.0);
  bad.cx_px = std::nan("");
  ExpectInputError([&] { WriteColmapModel(dir.path(), {bad}, options); },
                   {"camera 'typical'", "cx_px"});
  options.mm_per_unit = 0;
  ExpectInputError([&] { WriteColmapModel(dir.path(), {TypicalCamera(0.0)}, options); },
                   {"ColmapWriteOptions.mm_per_unit"});
  ExpectInputError([&] { WriteColmapModel("/nonexistent/dir", {TypicalCamera(0.0)}, {}); },
                   {"/nonexistent/dir/cameras.txt", "cannot open"});
}

}  // namespace
}  // namespace dome::geometry
