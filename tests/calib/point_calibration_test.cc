// One camera from correspondences (calib/point_calibration.h): noise-free synthetic
// points, coplanar and not, give back the camera that made them; the error figures
// are Willson's, recomputed here from their definitions; bad files and degenerate
// points are refused by name.
#include "calib/point_calibration.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "io/file_util.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::calib {
namespace {

geometry::TsaiCamera TrueCamera() {
  geometry::TsaiCamera c;
  c.id = "cam";
  c.width_px = 640;
  c.height_px = 480;
  c.sensor = {640, 640, 0.0088, 0.0088};
  c.focal_mm = 8.0;
  c.kappa1_per_mm2 = 2.0e-3;
  c.cx_px = 322.5;
  c.cy_px = 236.0;
  c.sx = 1.0;  // coplanar points cannot determine sx: keep it 1 for both cases
  c.rotation = geometry::RotationFromTsaiAngles(2.6, 0.2, -0.15);
  c.translation_mm = Eigen::Vector3d(-120, 80, 900);
  return c;
}

CameraPrior Prior(const geometry::TsaiCamera& c) {
  return {c.id, c.width_px, c.height_px, c.sensor};
}

// Grid points seen by `cam`: on z = 0, or on three depths when !coplanar.
std::vector<Correspondence> Points(const geometry::TsaiCamera& cam, bool coplanar) {
  std::vector<Correspondence> out;
  for (int k = 0; k < (coplanar ? 1 : 3); ++k) {
    for (int j = -5; j <= 5; ++j) {
      for (int i = -5; i <= 5; ++i) {
        Correspondence c;
        c.id = int(out.size());
        c.target_mm = Eigen::Vector3d(25.0 * i, 25.0 * j, coplanar ? 0.0 : -60.0 * k);
        if (!cam.Project(c.target_mm, &c.pixel)) continue;
        if (c.pixel.x() < 0 || c.pixel.y() < 0 || c.pixel.x() > 639 || c.pixel.y() > 479) continue;
        out.push_back(c);
      }
    }
  }
  return out;
}

void ExpectSameCamera(const geometry::TsaiCamera& a, const geometry::TsaiCamera& b) {
  EXPECT_NEAR(a.focal_mm, b.focal_mm, 1e-6 * b.focal_mm);
  EXPECT_NEAR(a.kappa1_per_mm2, b.kappa1_per_mm2, 1e-8);
  EXPECT_NEAR(a.cx_px, b.cx_px, 1e-4);
  EXPECT_NEAR(a.cy_px, b.cy_px, 1e-4);
  EXPECT_NEAR(a.sx, b.sx, 1e-7);
  EXPECT_LT((a.rotation - b.rotation).norm(), 1e-7);
  EXPECT_LT((a.translation_mm - b.translation_mm).norm(), 1e-4);
}

TEST(PointCalibration, NonCoplanarPointsGiveBackTheCamera) {
  const geometry::TsaiCamera truth = TrueCamera();
  const PointCalibration r = CalibrateFromPoints(Prior(truth), Points(truth, false), "points");
  EXPECT_FALSE(r.coplanar);
  ExpectSameCamera(r.camera, truth);
  EXPECT_LT(r.distorted_px.max, 1e-6);
  EXPECT_LT(r.object_mm.max, 1e-5);
}

TEST(PointCalibration, CoplanarPointsGiveBackTheCamera) {
  const geometry::TsaiCamera truth = TrueCamera();
  const PointCalibration r = CalibrateFromPoints(Prior(truth), Points(truth, true), "points");
  EXPECT_TRUE(r.coplanar);
  ExpectSameCamera(r.camera, truth);
  EXPECT_EQ(r.camera.sx, 1.0);
}

TEST(PointCalibration, ErrorFiguresAreWillsons) {
  // The true camera against observations moved by known offsets.
  const geometry::TsaiCamera cam = TrueCamera();
  std::vector<Correspondence> pts = Points(cam, false);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0, 0.5);
  for (auto& p : pts) p.pixel += Eigen::Vector2d(noise(rng), noise(rng));
  PointCalibration r;
  EvaluatePoints(cam, pts, &r);
  // Recomputed from the definitions.
  double sum = 0, worst = 0, osum = 0, nsum = 0;
  const double f = cam.focal_mm, dpx = cam.sensor.dpx_mm(), dpy = cam.sensor.dpy_mm();
  for (const auto& p : pts) {
    Eigen::Vector2d px;
    ASSERT_TRUE(cam.Project(p.target_mm, &px));
    const double e = (px - p.pixel).norm();
    sum += e;
    worst = std::max(worst, e);
    // Object space: distance of the point from the observed pixel's line of sight.
    const Eigen::Vector3d ray = cam.BackProject(p.pixel);
    const Eigen::Vector3d v = p.target_mm - cam.CentreWorld();
    osum += v.cross(ray).norm();
    // Weng's normalized error with the camera-frame point (x, y, z).
    const Eigen::Vector3d pc = cam.WorldToCamera(p.target_mm);
    const Eigen::Vector2d s = cam.PixelToSensor(p.pixel);
    const Eigen::Vector2d u = s * (1 + cam.kappa1_per_mm2 * s.squaredNorm());
    const double xh = u.x() * pc.z() / f, yh = u.y() * pc.z() / f;
    nsum += std::sqrt(((xh - pc.x()) * (xh - pc.x()) + (yh - pc.y()) * (yh - pc.y())) /
                      (pc.z() * pc.z() * (dpx * dpx / (f * f) + dpy * dpy / (f * f)) / 12));
  }
  const double n = double(pts.size());
  EXPECT_NEAR(r.distorted_px.mean, sum / n, 1e-9);
  EXPECT_NEAR(r.distorted_px.max, worst, 1e-9);
  EXPECT_NEAR(r.object_mm.mean, osum / n, 1e-9);
  EXPECT_NEAR(r.normalized_error, nsum / n, 1e-6);
  EXPECT_GT(r.distorted_px.mean, 0.4);  // half-pixel noise is seen
  EXPECT_NE(r.Report().find("normalized calibration error"), std::string::npos);
}

TEST(PointCalibration, BadFilesAndDegeneratePointsAreNamed) {
  const dome::testing::TempDir tmp;
  const auto file = tmp / "p.txt";
  io::WriteFileAtomically(file, "x,y,z,Xf,Yf\n1,2,3,4,5\n1 2 3 4\n");
  dome::testing::ExpectInputError([&] { ReadPointFile(file); }, {"p.txt:3", "expected 5 numbers"});
  io::WriteFileAtomically(file, "# nothing\n");
  dome::testing::ExpectInputError([&] { ReadPointFile(file); }, {"p.txt", "no correspondence"});
  const geometry::TsaiCamera cam = TrueCamera();
  std::vector<Correspondence> pts = Points(cam, false);
  pts.resize(6);
  dome::testing::ExpectInputError([&] { CalibrateFromPoints(Prior(cam), pts, "p.txt"); },
                                  {"p.txt", "at least 7"});
  std::vector<Correspondence> line;
  for (int i = 0; i < 10; ++i) {
    Correspondence c;
    c.target_mm = Eigen::Vector3d(10.0 * i, 5.0 * i, 0);
    cam.Project(c.target_mm, &c.pixel);
    line.push_back(c);
  }
  dome::testing::ExpectInputError([&] { CalibrateFromPoints(Prior(cam), line, "p.txt"); },
                                  {"p.txt", "collinear"});
}

}  // namespace
}  // namespace dome::calib
