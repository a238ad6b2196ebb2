#include "calib/tsai_calibration.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "geometry/tsai_camera.h"
#include "testing/expect_error.h"

namespace dome::calib {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

geometry::TsaiCamera TrueCamera() {
  geometry::TsaiCamera cam;
  cam.id = "cam";
  cam.width_px = 320;
  cam.height_px = 245;
  cam.sensor = {640, 320, 0.01, 0.0196};
  cam.focal_mm = 3.3;
  cam.kappa1_per_mm2 = 1.5e-3;
  cam.cx_px = 161.2;
  cam.cy_px = 120.7;
  cam.sx = 1.008;
  cam.rotation = geometry::RotationFromTsaiAngles(2.3, 0.4, -0.3);
  const Vector3d centre(1500, -900, 1800);
  cam.translation_mm = -cam.rotation * centre;
  return cam;
}

CameraPrior PriorOf(const geometry::TsaiCamera& cam) {
  return {cam.id, cam.width_px, cam.height_px, cam.sensor};
}

// Points on three orthogonal plates (like the synthetic object), projected exactly.
std::vector<Correspondence> ObjectPoints(const geometry::TsaiCamera& cam, bool volume,
                                         double noise_px = 0) {
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, noise_px);
  std::vector<Correspondence> out;
  int id = 0;
  for (int plate = 0; plate < (volume ? 3 : 1); ++plate) {
    for (int j = 1; j <= 7; ++j) {
      for (int i = 1; i <= 7; ++i) {
        Vector3d p = plate == 0   ? Vector3d(100 * i, 100 * j, 0)
                     : plate == 1 ? Vector3d(100 * j, 0, 100 * i)
                                  : Vector3d(0, 100 * i, 100 * j);
        Vector2d px;
        if (!cam.Project(p, &px)) continue;
        if (noise_px > 0) px += Vector2d(n(rng), n(rng));
        out.push_back({id++, p, px});
      }
    }
  }
  return out;
}

TEST(TsaiInit, NonCoplanarExactWithoutDistortion) {
  geometry::TsaiCamera truth = TrueCamera();
  truth.kappa1_per_mm2 = 0;
  // look at the object from the (1, 1, 1) side
  const Vector3d centre(2000, 1800, 1600), at(300, 300, 300);
  const Vector3d z = (at - centre).normalized(), x = z.cross(Vector3d(0, 0, -1)).normalized(),
                 y = z.cross(x);
  truth.rotation.row(0) = x;
  truth.rotation.row(1) = y;
  truth.rotation.row(2) = z;
  truth.translation_mm = -truth.rotation * centre;
  const auto pts = ObjectPoints(truth, true);
  const auto cam = TsaiInitNonCoplanar(PriorOf(truth), truth.cx_px, truth.cy_px, pts, {}, "test");
  EXPECT_NEAR(cam.focal_mm, truth.focal_mm, 1e-9);
  EXPECT_NEAR(cam.sx, truth.sx, 1e-9);
  EXPECT_LT((cam.rotation - truth.rotation).norm(), 1e-9);
  EXPECT_LT((cam.translation_mm - truth.translation_mm).norm(), 1e-6);
}

TEST(TsaiRefine, RecoversAllElevenParametersFromNoisyObjectPoints) {
  geometry::TsaiCamera truth = TrueCamera();
  const Vector3d centre(1100, 1000, 900), at(300, 300, 300);
  const Vector3d z = (at - centre).normalized(), x = z.cross(Vector3d(0, 0, -1)).normalized(),
                 y = z.cross(x);
  truth.rotation.row(0) = x;
  truth.rotation.row(1) = y;
  truth.rotation.row(2) = z;
  truth.translation_mm = -truth.rotation * centre;
  const auto pts = ObjectPoints(truth, true, 0.05);
  auto cam = TsaiInitNonCoplanar(PriorOf(truth), 159.5, 122.0, pts, {}, "test");
  std::vector<View> views{View{"v", pts, cam.rotation, cam.translation_mm}};
  RefineOptions centre_fixed;
  centre_fixed.refine_centre = false;
  RefineCamera(&cam, &views, centre_fixed, "test");  // as the pipeline: centre last
  const RefineSummary s = RefineCamera(&cam, &views, {}, "test");
  // the truth lies within a few standard deviations of the estimate
  EXPECT_LT(std::abs(cam.kappa1_per_mm2 - truth.kappa1_per_mm2), 4 * s.sigma.kappa1_per_mm2 + 1e-9);
  EXPECT_LT(std::abs(cam.focal_mm - truth.focal_mm), 4 * s.sigma.focal_mm + 1e-9);
  EXPECT_LT(s.final_rms_px, 0.08) << s.BriefReport();
  EXPECT_NEAR(cam.focal_mm / truth.focal_mm, 1.0, 0.01);
  EXPECT_NEAR(cam.cx_px, truth.cx_px, 0.5);
  EXPECT_NEAR(cam.cy_px, truth.cy_px, 0.5);
  EXPECT_NEAR(cam.sx, truth.sx, 1e-3);
  EXPECT_GT(s.sigma.focal_mm, 0.0);
  EXPECT_LT(s.sigma.focal_mm, 0.01);
  // noiseless: exact
  const auto exact = ObjectPoints(truth, true);
  auto cam2 = TsaiInitNonCoplanar(PriorOf(truth), 159.5, 122.0, exact, {}, "test");
  std::vector<View> views2{View{"v", exact, cam2.rotation, cam2.translation_mm}};
  RefineCamera(&cam2, &views2, {}, "test");
  EXPECT_NEAR(cam2.focal_mm, truth.focal_mm, 1e-6);
  EXPECT_NEAR(cam2.kappa1_per_mm2, truth.kappa1_per_mm2, 1e-7);
  EXPECT_NEAR(cam2.cx_px, truth.cx_px, 1e-4);
  EXPECT_LT((views2[0].rotation - truth.rotation).norm(), 1e-7);
  EXPECT_LT((views2[0].translation_mm - truth.translation_mm).norm(), 1e-4);
}

TEST(TsaiInit, CoplanarPoseWithKnownIntrinsics) {
  const geometry::TsaiCamera truth = TrueCamera();
  std::vector<Correspondence> pts;
  for (int r = 0; r < 5; ++r) {
    for (int c = 0; c < 5; ++c) {
      const Vector3d p(-600 + 300 * c, -600 + 300 * r, 0);
      Vector2d px;
      ASSERT_TRUE(truth.Project(p, &px));
      pts.push_back({5 * r + c, p, px});
    }
  }
  auto cam = TsaiInitCoplanar(truth, pts, true, {}, "test");
  EXPECT_LT((cam.rotation - truth.rotation).norm(), 1e-6);
  EXPECT_LT((cam.translation_mm - truth.translation_mm).norm(), 1e-2);
  auto free_f = TsaiInitCoplanar(truth, pts, false, {}, "test");
  EXPECT_NEAR(free_f.focal_mm, truth.focal_mm, 1e-6);
}

TEST(TsaiInit, TooFewPoints) {
  const auto truth = TrueCamera();
  auto pts = ObjectPoints(truth, true);
  pts.resize(6);
  testing::ExpectInputError(
      [&] { TsaiInitNonCoplanar(PriorOf(truth), 160, 122, pts, {}, "view.json"); },
      {"view.json", "6 calibration points", "at least 11"});
  pts.resize(4);
  testing::ExpectInputError([&] { TsaiInitCoplanar(truth, pts, true, {}, "floor.json"); },
                            {"floor.json", "4 calibration points", "at least 8"});
}

TEST(TsaiInit, CoplanarPointsWhereStageOneNeedsAVolume) {
  const auto truth = TrueCamera();
  const auto pts = ObjectPoints(truth, false);
  testing::ExpectInputError(
      [&] { TsaiInitNonCoplanar(PriorOf(truth), 160, 122, pts, {}, "stage1/c00.json"); },
      {"stage1/c00.json", "coplanar", "volume"});
}

TEST(TsaiInit, PointsBehindTheCamera) {
  geometry::TsaiCamera truth = TrueCamera();
  truth.kappa1_per_mm2 = 0;
  auto pts = ObjectPoints(truth, true);
  // Half the points mirrored through the camera centre: same pixels, behind the camera.
  const Vector3d c = truth.CentreWorld();
  for (size_t i = 0; i < pts.size(); i += 2) pts[i].target_mm = 2 * c - pts[i].target_mm;
  testing::ExpectInputError(
      [&] { TsaiInitNonCoplanar(PriorOf(truth), truth.cx_px, truth.cy_px, pts, {}, "v.json"); },
      {"v.json", "behind the camera"});
}

TEST(TsaiInit, NanPointIsRejected) {
  const auto truth = TrueCamera();
  auto pts = ObjectPoints(truth, true);
  pts[3].pixel.x() = std::nan("");
  testing::ExpectInputError(
      [&] { TsaiInitNonCoplanar(PriorOf(truth), 160, 122, pts, {}, "v.json"); },
      {"v.json", "point 3", "finite"});
}

TEST(TsaiRefine, TooFewResiduals) {
  const auto truth = TrueCamera();
  auto pts = ObjectPoints(truth, true);
  pts.resize(5);
  geometry::TsaiCamera cam = truth;
  std::vector<View> views{View{"v", pts, truth.rotation, truth.translation_mm}};
  testing::ExpectInputError([&] { RefineCamera(&cam, &views, {}, "v.json"); },
                            {"v.json", "too few points"});
}

}  // namespace
}  // namespace dome::calib

namespace dome::calib {
namespace {

// The centroid of a dot's image against a brute-force one: the image plane sampled on
// a fine grid, each sample's ray cut with the dot's plane (undistorting the sample
// first), the samples inside the dot averaged.
TEST(DotCentroid, OffsetMatchesTheCentroidOfTheImagedDisc) {
  geometry::TsaiCamera cam;
  cam.width_px = 320;
  cam.height_px = 245;
  cam.sensor = {640, 320, 0.01, 0.0196};
  cam.focal_mm = 3.3;
  cam.kappa1_per_mm2 = 1.8e-3;
  cam.cx_px = 160.0;
  cam.cy_px = 122.0;
  cam.sx = 1.0;
  View view;
  view.rotation = Eigen::AngleAxisd(0.9, Vector3d(1, 0.3, 0).normalized()).toRotationMatrix();
  view.translation_mm = Vector3d(-150, 80, 420);
  const Vector3d centre(-60, 90, 0), normal(0, 0, 1);
  const double radius = 30.0;
  const Vector2d offset = DotCentroidOffsetPx(cam, view, centre, normal, radius);

  geometry::TsaiCamera posed = cam;
  posed.rotation = view.rotation;
  posed.translation_mm = view.translation_mm;
  Vector2d centre_px;
  ASSERT_TRUE(posed.Project(centre, &centre_px));
  const Vector3d origin = -view.rotation.transpose() * view.translation_mm;
  double sx = 0, sy = 0;
  long inside = 0;
  constexpr double kStep = 0.02;  // px
  for (double y = centre_px.y() - 25; y <= centre_px.y() + 25; y += kStep) {
    for (double x = centre_px.x() - 25; x <= centre_px.x() + 25; x += kStep) {
      const Vector2d u = cam.UndistortPixel(Vector2d(x, y));
      const Vector3d ray_camera((u.x() - cam.cx_px) * cam.sensor.dpx_mm() / cam.sx / cam.focal_mm,
                                (u.y() - cam.cy_px) * cam.sensor.dpy_mm() / cam.focal_mm, 1.0);
      const Vector3d ray = view.rotation.transpose() * ray_camera;
      const double t = -origin.z() / ray.z();  // the plane z = 0
      if (t <= 0) continue;
      if ((origin + t * ray - centre).norm() > radius) continue;
      sx += x;
      sy += y;
      ++inside;
    }
  }
  ASSERT_GT(inside, 100000);
  const Vector2d brute = Vector2d(sx, sy) / static_cast<double>(inside) - centre_px;
  // a visible shift, which the outline polygon reproduces to a few thousandths of a px
  EXPECT_GT(offset.norm(), 0.05);
  EXPECT_NEAR(offset.x(), brute.x(), 0.003);
  EXPECT_NEAR(offset.y(), brute.y(), 0.003);
}

}  // namespace
}  // namespace dome::calib

namespace dome::calib {
namespace {

// The stage-1 object looks the same after a 120 deg turn about its diagonal, (x, y, z)
// -> (z, x, y), so a detector may label a view's dots turned by it. The labelling is
// then that of the object in another pose: each view has its own pose, so the
// intrinsics come out the same; a mirrored labelling fits no pose.
TEST(TsaiRefine, ObjectLabelledTurnedBy120DegreesGivesTheSameIntrinsics) {
  const geometry::TsaiCamera truth = TrueCamera();
  auto look = [&](const Vector3d& centre) {
    geometry::TsaiCamera cam = truth;
    const Vector3d at(300, 300, 300);
    const Vector3d z = (at - centre).normalized(), x = z.cross(Vector3d(0, 0, -1)).normalized();
    cam.rotation.row(0) = x;
    cam.rotation.row(1) = z.cross(x);
    cam.rotation.row(2) = z;
    cam.translation_mm = -cam.rotation * centre;
    return cam;
  };
  const geometry::TsaiCamera a = look(Vector3d(1100, 1000, 900));
  const geometry::TsaiCamera b = look(Vector3d(900, 1200, 1000));
  Eigen::Matrix3d turn;
  turn << 0, 0, 1, 1, 0, 0, 0, 1, 0;  // (x, y, z) -> (z, x, y)
  auto calibrate = [&](const Eigen::Matrix3d& relabel, double* rms) {
    std::vector<Correspondence> pa = ObjectPoints(a, true), pb = ObjectPoints(b, true);
    for (auto& c : pb) c.target_mm = relabel * c.target_mm;
    std::vector<View> views;
    geometry::TsaiCamera cam;
    for (const auto* points : {&pa, &pb}) {
      cam = TsaiInitNonCoplanar(PriorOf(truth), 159.5, 122.0, *points, {}, "test");
      views.push_back(View{"v", *points, cam.rotation, cam.translation_mm});
    }
    const RefineSummary s = RefineCamera(&cam, &views, {}, "test");
    *rms = s.final_rms_px;
    return cam;
  };
  double rms = 0;
  const geometry::TsaiCamera turned = calibrate(turn, &rms);
  EXPECT_LT(rms, 1e-6);
  EXPECT_NEAR(turned.focal_mm, truth.focal_mm, 1e-6);
  EXPECT_NEAR(turned.kappa1_per_mm2, truth.kappa1_per_mm2, 1e-8);
  EXPECT_NEAR(turned.cx_px, truth.cx_px, 1e-4);
  EXPECT_NEAR(turned.cy_px, truth.cy_px, 1e-4);
  EXPECT_NEAR(turned.sx, truth.sx, 1e-7);
  Eigen::Matrix3d mirror;
  mirror << 0, 1, 0, 1, 0, 0, 0, 0, 1;  // x <-> y: plates y = 0 and x = 0 swapped
  bool rejected = false;                // by the closed form (points behind the camera), or
  try {
    calibrate(mirror, &rms);
  } catch (const core::InputError&) {
    rejected = true;
  }
  EXPECT_TRUE(rejected || rms > 1.0) << rms;  // by the refinement
}

}  // namespace
}  // namespace dome::calib
