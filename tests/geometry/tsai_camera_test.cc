#include "geometry/tsai_camera.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <vector>

#include "geometry_test_util.h"
#include "testing/expect_error.h"

namespace dome::geometry {
namespace {

using testing::ExpectInputError;
using testing::TypicalCamera;

// Realistic magnitudes for a 720x576 camera with 23 um pixels (the sensor diagonal is
// ~21 mm): EPFL's kappa1 are +3.5e-4..+5.7e-4; the negative ones keep the corner below
// the radius where the model folds (Rd_max = 1/sqrt(-3 kappa1) = 18 mm at -1e-3).
const double kKappas[] = {5.720865e-04, 2e-3, 1e-8, -1e-8, -5e-4, -1e-3};

// Willson's undistorted_to_distorted_sensor_coord (cal_tran.c, v3.0b3), transcribed as
// an independent reference: Cardano's formula for kappa Rd^3 + Rd - Ru = 0.
double WillsonDistortedRadius(double ru, double kappa) {
  const double c = 1.0 / kappa;
  const double d = -c * ru;
  const double q = c / 3.0;
  const double r = -d / 2.0;
  double disc = q * q * q + r * r;
  if (disc >= 0.0) {
    disc = std::sqrt(disc);
    const double rd = std::cbrt(r + disc) + std::cbrt(r - disc);
    return rd < 0.0 ? std::sqrt(-1.0 / (3.0 * kappa)) : rd;
  }
  disc = std::sqrt(-disc);
  const double s = std::cbrt(std::hypot(r, disc));
  const double t = std::atan2(disc, r) / 3.0;
  return -s * std::cos(t) + std::sqrt(3.0) * s * std::sin(t);  // the smaller positive root
}

// A camera at the world origin looking down +Z, square 10 um pixels: easy to compute by
// hand.
TsaiCamera HandCamera(double kappa1) {
  TsaiCamera camera;
  camera.id = "hand";
  camera.width_px = 640;
  camera.height_px = 480;
  camera.sensor.dx_mm = 0.01;
  camera.sensor.dy_mm = 0.01;
  camera.focal_mm = 10.0;
  camera.kappa1_per_mm2 = kappa1;
  camera.cx_px = 320.0;
  camera.cy_px = 240.0;
  camera.translation_mm = Eigen::Vector3d(0.0, 0.0, 1000.0);
  return camera;
}

TEST(TsaiAngles, MatchWillsonMatrixAndRzRyRx) {
  const double rx = 0.3, ry = -0.7, rz = 2.1;
  const Eigen::Matrix3d expected = (Eigen::AngleAxisd(rz, Eigen::Vector3d::UnitZ()) *
                                    Eigen::AngleAxisd(ry, Eigen::Vector3d::UnitY()) *
                                    Eigen::AngleAxisd(rx, Eigen::Vector3d::UnitX()))
                                       .toRotationMatrix();
  EXPECT_LT((RotationFromTsaiAngles(rx, ry, rz) - expected).cwiseAbs().maxCoeff(), 1e-15);
  // Spot-check Willson's entries: r7 = -sin(ry), r8 = cos(ry) sin(rx), r3 = sa sg + ca cg sb.
  const Eigen::Matrix3d r = RotationFromTsaiAngles(rx, ry, rz);
  EXPECT_DOUBLE_EQ(r(2, 0), -std::sin(ry));
  EXPECT_DOUBLE_EQ(r(2, 1), std::cos(ry) * std::sin(rx));
  EXPECT_DOUBLE_EQ(r(0, 2),
                   std::sin(rx) * std::sin(rz) + std::cos(rx) * std::cos(rz) * std::sin(ry));
}

TEST(TsaiAngles, RoundTrip) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(-M_PI + 1e-9, M_PI);
  std::uniform_real_distribution<double> tilt(-M_PI / 2 + 1e-6, M_PI / 2 - 1e-6);
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d angles(angle(rng), tilt(rng), angle(rng));
    const Eigen::Matrix3d r = RotationFromTsaiAngles(angles.x(), angles.y(), angles.z());
    const Eigen::Vector3d back = TsaiAnglesFromRotation(r);
    EXPECT_LT((back - angles).cwiseAbs().maxCoeff(), 1e-9) << angles.transpose();
    const Eigen::Matrix3d again = RotationFromTsaiAngles(back.x(), back.y(), back.z());
    EXPECT_LT((again - r).cwiseAbs().maxCoeff(), 1e-14);
  }
}

TEST(TsaiAngles, GimbalLockStillReproducesTheRotation) {
  for (const double ry : {M_PI / 2, -M_PI / 2}) {
    const Eigen::Matrix3d r = RotationFromTsaiAngles(0.4, ry, -1.1);
    const Eigen::Vector3d back = TsaiAnglesFromRotation(r);
    EXPECT_EQ(back.x(), 0.0);
    EXPECT_LT((RotationFromTsaiAngles(back.x(), back.y(), back.z()) - r).cwiseAbs().maxCoeff(),
              1e-12);
  }
}

TEST(TsaiCamera, ProjectsHandComputedPoints) {
  // kappa1 = 0: Xc = (100, 50, 1000) -> Xu = 10 * 100 / 1000 = 1 mm, Yu = 0.5 mm
  //   -> Xf = 1 / 0.01 + 320 = 420, Yf = 0.5 / 0.01 + 240 = 290.
  Eigen::Vector2d pixel;
  ASSERT_TRUE(HandCamera(0.0).Project(Eigen::Vector3d(100, 50, 0), &pixel));
  EXPECT_NEAR(pixel.x(), 420.0, 1e-12);
  EXPECT_NEAR(pixel.y(), 290.0, 1e-12);

  // kappa1 = 0.25 / mm^2: Xc = (75, 100, 1000) -> (Xu, Yu) = (0.75, 1.0), Ru = 1.25.
  // Rd (1 + 0.25 Rd^2) = 1.25 has the root Rd = 1 (the only real one), so
  // (Xd, Yd) = (0.75, 1.0) / 1.25 = (0.6, 0.8) -> pixel (380, 320).
  ASSERT_TRUE(HandCamera(0.25).Project(Eigen::Vector3d(75, 100, 0), &pixel));
  EXPECT_NEAR(pixel.x(), 380.0, 1e-12);
  EXPECT_NEAR(pixel.y(), 320.0, 1e-12);

  // kappa1 = -0.2 / mm^2: Xc = (48, 64, 1000) -> (Xu, Yu) = (0.48, 0.64), Ru = 0.8.
  // Rd (1 - 0.2 Rd^2) = 0.8: roots 1, (-1 +- sqrt(17)) / 2 = 1.5616, -2.5616; the
  // physical one is the smallest positive (below the fold at 1/sqrt(0.6) = 1.29):
  // Rd = 1 -> (Xd, Yd) = (0.6, 0.8) -> pixel (380, 320).
  ASSERT_TRUE(HandCamera(-0.2).Project(Eigen::Vector3d(48, 64, 0), &pixel));
  EXPECT_NEAR(pixel.x(), 380.0, 1e-12);
  EXPECT_NEAR(pixel.y(), 320.0, 1e-12);

  // sx and ncx / nfx: dpx = 0.01 * 800 / 640 = 0.0125 mm, sx = 1.25:
  // Xf = 1.25 * 0.6 / 0.0125 + 320 = 380 again.
  TsaiCamera scaled = HandCamera(0.25);
  scaled.sensor.ncx = 800;
  scaled.sensor.nfx = 640;
  scaled.sx = 1.25;
  ASSERT_TRUE(scaled.Project(Eigen::Vector3d(75, 100, 0), &pixel));
  EXPECT_NEAR(pixel.x(), 380.0, 1e-12);
  EXPECT_NEAR(pixel.y(), 320.0, 1e-12);
  // K: fx = 10 * 1.25 / 0.0125 = 1000, fy = 10 / 0.01 = 1000.
  const Eigen::Matrix3d k = scaled.K();
  EXPECT_NEAR(k(0, 0), 1000.0, 1e-12);
  EXPECT_NEAR(k(1, 1), 1000.0, 1e-12);
  EXPECT_EQ(k(0, 1), 0.0);
  EXPECT_EQ(k(0, 2), 320.0);
  EXPECT_EQ(k(1, 2), 240.0);
  EXPECT_EQ(k(2, 2), 1.0);
}

TEST(TsaiCamera, PointsBehindTheCameraDoNotProject) {
  const TsaiCamera camera = HandCamera(0.0);
  Eigen::Vector2d pixel(-7.0, -7.0);
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(0, 0, -1000), &pixel));  // Zc = 0
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(0, 0, -2000), &pixel));  // Zc < 0
  EXPECT_FALSE(camera.ProjectCamera(Eigen::Vector3d(0, 0, std::nan("")), &pixel));
  EXPECT_EQ(pixel, Eigen::Vector2d(-7.0, -7.0));
}

// The keys of what is kept per camera: the id never counts; every number of the model
// counts in IntrinsicsKey, and the pose too in Key.
TEST(TsaiCamera, KeysHoldEveryNumberButTheId) {
  const TsaiCamera camera = TypicalCamera(5e-4);
  TsaiCamera renamed = camera;
  renamed.id = "another";
  EXPECT_EQ(renamed.IntrinsicsKey(), camera.IntrinsicsKey());
  EXPECT_EQ(renamed.Key(), camera.Key());
  const std::vector<std::function<void(TsaiCamera*)>> intrinsic = {
      [](TsaiCamera* c) { c->width_px += 1; },       [](TsaiCamera* c) { c->sensor.nfx += 1; },
      [](TsaiCamera* c) { c->focal_mm *= 1.001; },   [](TsaiCamera* c) { c->kappa1_per_mm2 = 0; },
      [](TsaiCamera* c) { c->lens.k3 = 1e-3; },      [](TsaiCamera* c) { c->lens.p2 = 1e-4; },
      [](TsaiCamera* c) { c->cy_px += 0.25; },       [](TsaiCamera* c) { c->sx *= 1.0001; }};
  for (size_t i = 0; i < intrinsic.size(); ++i) {
    TsaiCamera other = camera;
    intrinsic[i](&other);
    EXPECT_NE(other.IntrinsicsKey(), camera.IntrinsicsKey()) << "change " << i;
    EXPECT_NE(other.Key(), camera.Key()) << "change " << i;
  }
  TsaiCamera moved = camera;
  moved.translation_mm.z() += 1;
  EXPECT_EQ(moved.IntrinsicsKey(), camera.IntrinsicsKey());
  EXPECT_NE(moved.Key(), camera.Key());
  TsaiCamera turned = camera;
  turned.rotation =
      Eigen::Matrix3d(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitY())) * camera.rotation;
  EXPECT_NE(turned.Key(), camera.Key());
}

TEST(TsaiCamera, CentreIsWhereTheCameraFrameStarts) {
  const TsaiCamera camera = TypicalCamera(5e-4);
  EXPECT_LT(camera.WorldToCamera(camera.CentreWorld()).norm(), 1e-9);
}

TEST(TsaiCamera, DistortedRadiusAgreesWithWillsonsCardano) {
  for (const double kappa : {5.720865e-04, 2e-3, -5e-4, -1e-3, 0.25, -0.2}) {
    const double ru_max = kappa < 0 ? 2.0 / (3.0 * std::sqrt(-3.0 * kappa)) : 20.0;
    for (int i = 1; i <= 200; ++i) {
      const double ru = ru_max * i / 201.0;
      double rd;
      ASSERT_TRUE(DistortedRadiusMm(ru, kappa, &rd));
      EXPECT_NEAR(rd, WillsonDistortedRadius(ru, kappa), 1e-10 * ru) << kappa << " " << ru;
      EXPECT_NEAR(rd * (1.0 + kappa * rd * rd), ru, 1e-14 * ru) << kappa << " " << ru;
    }
  }
}

TEST(TsaiCamera, DistortedRadiusIsAccurateForTinyKappa) {
  // Cardano loses all digits here (Q^3 ~ 1e48); the hyperbolic form does not.
  for (const double kappa : {1e-16, -1e-16, 1e-12, -1e-12}) {
    double rd;
    ASSERT_TRUE(DistortedRadiusMm(10.0, kappa, &rd));
    EXPECT_NEAR(rd * (1.0 + kappa * rd * rd), 10.0, 1e-14);
  }
}

TEST(TsaiCamera, DistortUndistortRoundTripOverTheWholeImage) {
  for (const double kappa : kKappas) {
    const TsaiCamera camera = TypicalCamera(kappa);
    double worst = 0.0;
    for (double y = 0; y <= camera.height_px - 1; y += 3.7) {
      for (double x = 0; x <= camera.width_px - 1; x += 3.7) {
        const Eigen::Vector2d distorted(x, y);
        const Eigen::Vector2d ideal = camera.UndistortPixel(distorted);
        Eigen::Vector2d back;
        ASSERT_TRUE(camera.DistortPixelIfInRange(ideal, &back));
        worst = std::max(worst, (back - distorted).norm() / std::max(1.0, distorted.norm()));
        EXPECT_EQ(camera.DistortPixel(ideal), back);
        // And the other way: an ideal pixel -> distorted -> ideal.
        const Eigen::Vector2d there = camera.DistortPixel(distorted);
        worst = std::max(worst, (camera.UndistortPixel(there) - distorted).norm() /
                                    std::max(1.0, distorted.norm()));
      }
    }
    EXPECT_LT(worst, 1e-9) << "kappa1 " << kappa;
  }
}

TEST(TsaiCamera, DistortionDirectionFollowsTsai) {
  // kappa1 > 0: undistorted points lie farther from the centre than distorted ones.
  const TsaiCamera camera = TypicalCamera(5e-4);
  const Eigen::Vector2d centre(camera.cx_px, camera.cy_px);
  const Eigen::Vector2d corner(0.0, 0.0);
  EXPECT_GT((camera.UndistortPixel(corner) - centre).norm(), (corner - centre).norm());
  EXPECT_EQ(camera.UndistortPixel(centre), centre);
  EXPECT_EQ(camera.DistortPixel(centre), centre);
}

TEST(TsaiCamera, NegativeKappaBeyondTheFoldIsClampedOrReported) {
  TsaiCamera camera = HandCamera(-0.2);
  // Ru_max = 2 / (3 sqrt(0.6)) = 0.8607 mm = 86.07 px; Rd there = 1/sqrt(0.6) = 129.1 px.
  const Eigen::Vector2d far(320.0 + 100.0, 240.0);
  Eigen::Vector2d out(-1.0, -1.0);
  EXPECT_FALSE(camera.DistortPixelIfInRange(far, &out));
  EXPECT_EQ(out, Eigen::Vector2d(-1.0, -1.0));
  const Eigen::Vector2d clamped = camera.DistortPixel(far);
  EXPECT_NEAR(clamped.x(), 320.0 + 100.0 / std::sqrt(0.6), 1e-9);
  EXPECT_NEAR(clamped.y(), 240.0, 1e-12);
  const Eigen::Vector2d inside(320.0 + 80.0, 240.0);
  EXPECT_TRUE(camera.DistortPixelIfInRange(inside, &out));
}

TEST(TsaiCamera, ProjectBackProjectRoundTrip) {
  std::mt19937 rng(11);
  for (const double kappa : kKappas) {
    const TsaiCamera camera = TypicalCamera(kappa);
    std::uniform_real_distribution<double> px(0.0, camera.width_px - 1.0);
    std::uniform_real_distribution<double> py(0.0, camera.height_px - 1.0);
    std::uniform_real_distribution<double> depth(500.0, 50000.0);
    for (int i = 0; i < 2000; ++i) {
      const Eigen::Vector2d pixel(px(rng), py(rng));
      const double depth_mm = depth(rng);
      const Eigen::Vector3d world = camera.BackProjectAtDepth(pixel, depth_mm);
      EXPECT_NEAR(camera.WorldToCamera(world).z(), depth_mm, 1e-9 * depth_mm);
      Eigen::Vector2d back;
      ASSERT_TRUE(camera.Project(world, &back));
      EXPECT_LT((back - pixel).norm(), 1e-9 * std::max(1.0, pixel.norm())) << "kappa1 " << kappa;

      const Eigen::Vector3d ray = camera.BackProject(pixel);
      EXPECT_NEAR(ray.norm(), 1.0, 1e-12);
      ASSERT_TRUE(camera.Project(camera.CentreWorld() + 3000.0 * ray, &back));
      EXPECT_LT((back - pixel).norm(), 1e-9 * std::max(1.0, pixel.norm())) << "kappa1 " << kappa;
      EXPECT_LT(
          (camera.BackProjectAtDepth(pixel, depth_mm) - camera.CentreWorld()).normalized().dot(ray),
          1.0 + 1e-12);
    }
  }
}

TEST(TsaiCamera, SensorPixelRoundTrip) {
  const TsaiCamera camera = TypicalCamera(5e-4);
  const Eigen::Vector2d pixel(12.25, 500.5);
  EXPECT_LT((camera.SensorToPixel(camera.PixelToSensor(pixel)) - pixel).norm(), 1e-12);
  // Xd = (Xf - cx) dpx / sx.
  EXPECT_NEAR(camera.PixelToSensor(pixel).x(), (12.25 - camera.cx_px) * 0.023 / 1.013, 1e-14);
}

TEST(TsaiCamera, CheckAcceptsAValidCamera) {
  EXPECT_NO_THROW(TypicalCamera(5e-4).Check("rig.json: camera c0"));
}

TEST(TsaiCamera, CheckNamesTheField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const auto expect = [](const std::string& field, auto mutate) {
    TsaiCamera camera = TypicalCamera(5e-4);
    mutate(&camera);
    ExpectInputError([&] { camera.Check("rig.json: camera c0"); },
                     {"rig.json: camera c0: " + field});
  };
  expect("width_px", [](TsaiCamera* c) { c->width_px = 0; });
  expect("height_px", [](TsaiCamera* c) { c->height_px = -5; });
  expect("sensor.ncx", [&](TsaiCamera* c) { c->sensor.ncx = nan; });
  expect("sensor.nfx", [](TsaiCamera* c) { c->sensor.nfx = 0.0; });
  expect("sensor.dx_mm", [](TsaiCamera* c) { c->sensor.dx_mm = -0.01; });
  expect("sensor.dy_mm", [&](TsaiCamera* c) { c->sensor.dy_mm = inf; });
  expect("focal_mm", [](TsaiCamera* c) { c->focal_mm = 0.0; });
  expect("focal_mm", [&](TsaiCamera* c) { c->focal_mm = nan; });
  expect("kappa1_per_mm2", [&](TsaiCamera* c) { c->kappa1_per_mm2 = nan; });
  expect("cx_px", [&](TsaiCamera* c) { c->cx_px = inf; });
  expect("cy_px", [&](TsaiCamera* c) { c->cy_px = nan; });
  expect("sx", [](TsaiCamera* c) { c->sx = 0.0; });
  expect("translation_mm[2]", [&](TsaiCamera* c) { c->translation_mm.z() = nan; });
  expect("rotation(1,2)", [&](TsaiCamera* c) { c->rotation(1, 2) = nan; });
  expect("rotation", [](TsaiCamera* c) { c->rotation(0, 0) += 1e-5; });   // not orthonormal
  expect("rotation", [](TsaiCamera* c) { c->rotation.row(2) *= -1.0; });  // reflection
  // The message says what was expected.
  TsaiCamera camera = TypicalCamera(5e-4);
  camera.focal_mm = -3.0;
  ExpectInputError([&] { camera.Check("c0"); }, {"c0: focal_mm", "positive", "-3"});
  camera = TypicalCamera(5e-4);
  camera.rotation.row(2) *= -1.0;
  ExpectInputError([&] { camera.Check("c0"); }, {"determinant", "-1"});
  // Tolerances: 1e-7 off orthonormal is accepted.
  camera = TypicalCamera(5e-4);
  camera.rotation(0, 0) += 1e-7;
  EXPECT_NO_THROW(camera.Check("c0"));
}

}  // namespace
}  // namespace dome::geometry

namespace dome::geometry {
namespace {

// OpenCV's lens: a Panoptic-like strong barrel lens with tangential terms.
TsaiCamera LensCamera() {
  TsaiCamera c;
  c.id = "lens";
  c.width_px = 1920;
  c.height_px = 1080;
  c.sensor.ncx = c.sensor.nfx = 1920;
  c.focal_mm = 14.0;  // 1400 px at 0.01 mm
  c.sx = 1.002;
  c.cx_px = 955.3;
  c.cy_px = 541.8;
  c.lens = {-0.27, 0.21, 0.0007, -0.0004, -0.04};
  c.translation_mm = Eigen::Vector3d(10, -20, 3000);
  return c;
}

// The ideal camera of a lens camera projects where the lens camera's pixels land once
// undistorted (UndistortPixel), for OpenCV's lens as for kappa1: no distortion is left.
TEST(TsaiCamera, IdealDropsEitherLensAndProjectsToTheUndistortedPixel) {
  TsaiCamera kappa = LensCamera();
  kappa.lens = {};
  kappa.kappa1_per_mm2 = -2e-4;
  for (const TsaiCamera& c : {LensCamera(), kappa}) {
    const TsaiCamera ideal = c.Ideal();
    EXPECT_FALSE(ideal.HasDistortion()) << c.kappa1_per_mm2;
    EXPECT_EQ(ideal.K(), c.K());
    const Eigen::Vector3d p(1800, 900, 0);  // near the image corner
    Eigen::Vector2d distorted, undistorted;
    ASSERT_TRUE(c.Project(p, &distorted));
    ASSERT_TRUE(ideal.Project(p, &undistorted));
    EXPECT_GT((distorted - undistorted).norm(), 1.0) << "the lens moves this point";
    EXPECT_LT((c.UndistortPixel(distorted) - undistorted).norm(), 1e-6);
  }
}

TEST(OpenCvLens, ProjectAndBackProjectInvertEachOtherOverTheImage) {
  const TsaiCamera c = LensCamera();
  c.Check("test");
  double worst = 0;
  for (int y = 0; y < c.height_px; y += 53) {
    for (int x = 0; x < c.width_px; x += 61) {
      const Eigen::Vector2d px(x, y);
      Eigen::Vector2d back;
      ASSERT_TRUE(c.Project(c.BackProjectAtDepth(px, 2500.0), &back));
      worst = std::max(worst, (back - px).norm());
      EXPECT_LT((c.DistortPixel(c.UndistortPixel(px)) - px).norm(), 1e-8);
      // The ray of BackProject passes through the point at depth.
      const Eigen::Vector3d ray = c.BackProject(px);
      const Eigen::Vector3d p = c.BackProjectAtDepth(px, 2500.0) - c.CentreWorld();
      EXPECT_LT((p.normalized() - ray).norm(), 1e-9);
    }
  }
  EXPECT_LT(worst, 1e-8);
}

TEST(OpenCvLens, OneDistortionModelPerCamera) {
  TsaiCamera c = LensCamera();
  c.kappa1_per_mm2 = 1e-3;
  dome::testing::ExpectInputError([&] { c.Check("rig.json: camera lens"); },
                                  {"rig.json: camera lens: lens", "kappa1_per_mm2"});
  c.kappa1_per_mm2 = 0;
  c.lens.p1 = std::nan("");
  dome::testing::ExpectInputError([&] { c.Check("cam"); }, {"cam: lens.p1", "finite"});
}

}  // namespace
}  // namespace dome::geometry
