#include "synth/dome_rig.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <set>

#include "geometry/rig.h"
#include "synth/calib_target.h"
#include "synth/render.h"
#include "testing/expect_error.h"

namespace dome::synth {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

TEST(DomeRig, PaperDomeIsTheSeeds) {
  const auto cameras = MakeDomeRig(DomeRigOptions());
  ASSERT_EQ(cameras.size(), 51u);
  std::set<std::string> ids;
  geometry::Rig rig;
  for (const auto& cam : cameras) {
    const auto& m = cam.rig.model;
    ids.insert(m.id);
    rig.cameras.push_back(cam.rig);
    // On the 2.5 m sphere (5 m dome) around (0, 0, 250), above 26 degrees.
    EXPECT_NEAR((m.CentreWorld() - Vector3d(0, 0, 250)).norm(), 2500.0, 1e-6);
    EXPECT_GE(cam.elevation_deg, 26.5);
    // Looking inward: the aim point is near the image centre, in front.
    Vector2d px;
    ASSERT_TRUE(m.Project(Vector3d(0, 0, 900), &px));
    EXPECT_NEAR(px.x(), m.cx_px, 15.0);
    EXPECT_NEAR(px.y(), m.cy_px, 15.0);
    EXPECT_NEAR(m.rotation.determinant(), 1.0, 1e-12);
    EXPECT_LT((m.rotation * m.rotation.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    EXPECT_GT(m.kappa1_per_mm2, 0.0);  // barrel
    EXPECT_EQ(m.width_px, 320);
    EXPECT_EQ(m.height_px, 245);
    // Clusters of 4 to 7 cameras (seed §4.3).
    EXPECT_GE(cam.rig.neighbours.size(), 3u) << m.id;
    EXPECT_LE(cam.rig.neighbours.size(), 6u) << m.id;
    EXPECT_GT(cam.response.noise_sigma, 0.0);
  }
  EXPECT_EQ(ids.size(), 51u);
  EXPECT_NO_THROW(geometry::CheckRig(rig, "synthetic rig"));
  // Neighbours are mutual and close (a geodesic edge: ~30 degrees apart at most).
  for (const auto& cam : rig.cameras) {
    for (const auto& n : cam.neighbours) {
      const auto& other = rig.cameras[rig.Find(n)];
      EXPECT_NE(std::find(other.neighbours.begin(), other.neighbours.end(), cam.model.id),
                other.neighbours.end());
      EXPECT_LT((cam.model.CentreWorld() - other.model.CentreWorld()).norm(), 1000.0);
    }
  }
}

TEST(DomeRig, FieldOfViewIsAbout90By70WithVisibleBarrelDistortion) {
  for (const auto& cam : MakeDomeRig(DomeRigOptions())) {
    const auto& m = cam.rig.model;
    const CameraRays rays(m);
    const auto angle = [&](double x0, double y0, double x1, double y1) {
      const Vector3d a = rays.Direction(x0, y0).normalized(),
                     b = rays.Direction(x1, y1).normalized();
      return std::acos(a.dot(b)) * 180.0 / M_PI;
    };
    const double w = m.width_px, h = m.height_px;
    EXPECT_NEAR(angle(-0.5, m.cy_px, w - 0.5, m.cy_px), 90.0, 5.0) << m.id;
    EXPECT_NEAR(angle(m.cx_px, -0.5, m.cx_px, h - 0.5), 72.0, 5.0) << m.id;
    // Distortion at the image corner: a few pixels between the distorted and ideal images.
    const Vector2d corner(-0.5, -0.5);
    const double shift = (m.UndistortPixel(corner) - corner).norm();
    EXPECT_GT(shift, 2.5) << m.id;
    EXPECT_LT(shift, 8.0) << m.id;
  }
}

// The sensor constants describe the digitization exactly: a frame camera (2W x 2H
// samples, one sample per sensor element and line) sees a point at frame sample
// (j, r) iff the take camera sees it at ((j - 0.5) / 2, r / 2).
TEST(DomeRig, SensorConstantsDescribeTheDigitizedField) {
  const auto cameras = MakeDomeRig(DomeRigOptions());
  for (const auto& cam : {cameras[0], cameras[30]}) {
    const auto& m = cam.rig.model;
    geometry::TsaiCamera frame = m;
    frame.width_px = 2 * m.width_px;
    frame.height_px = 2 * m.height_px;
    frame.sensor.ncx = 2 * m.width_px;
    frame.sensor.nfx = 2 * m.width_px;
    frame.sensor.dy_mm = m.sensor.dy_mm / 2.0;
    frame.cx_px = 2.0 * m.cx_px + 0.5;
    frame.cy_px = 2.0 * m.cy_px;
    EXPECT_DOUBLE_EQ(m.sensor.dpx_mm(), 6.4 / 320);
    EXPECT_DOUBLE_EQ(frame.sensor.dpx_mm(), 6.4 / 640);
    EXPECT_DOUBLE_EQ(frame.sensor.dpy_mm(), 4.8 / 490);
    for (double x = -500; x <= 500; x += 250) {
      for (double y = -500; y <= 500; y += 250) {
        const Vector3d p(x, y, 1000 + 0.5 * x);
        Vector2d a, b;
        ASSERT_TRUE(m.Project(p, &a));
        ASSERT_TRUE(frame.Project(p, &b));
        const Vector2d expected = FrameSampleToImage(0, 0) + Vector2d(b.x() / 2.0, b.y() / 2.0);
        EXPECT_NEAR(a.x(), expected.x(), 1e-9);
        EXPECT_NEAR(a.y(), expected.y(), 1e-9);
      }
    }
  }
}

TEST(DomeRig, SmallDomesAndOtherSizes) {
  DomeRigOptions options;
  options.cameras = 6;
  options.width_px = 160;
  options.height_px = 120;
  const auto cameras = MakeDomeRig(options);
  ASSERT_EQ(cameras.size(), 6u);
  EXPECT_NEAR(cameras[0].elevation_deg, 90.0, 1e-9);
  EXPECT_EQ(cameras[0].rig.neighbours.size(), 5u);  // the top sees the ring
  for (int i = 1; i < 6; ++i) EXPECT_EQ(cameras[i].rig.neighbours.size(), 3u);
  EXPECT_EQ(cameras[0].rig.model.width_px, 160);
  // The same camera index gets the same parameters whatever the count.
  options.cameras = 3;
  const auto three = MakeDomeRig(options);
  EXPECT_EQ(three[1].rig.model.focal_mm, cameras[1].rig.model.focal_mm);
  EXPECT_EQ(three[1].rig.model.rotation, cameras[1].rig.model.rotation);
  options.cameras = 120;
  options.width_px = 320;
  options.height_px = 245;
  EXPECT_EQ(MakeDomeRig(options).size(), 120u);
}

TEST(DomeRig, BadOptionsNameTheFlag) {
  DomeRigOptions options;
  options.cameras = 0;
  testing::ExpectInputError([&] { options.Check(); }, {"--cameras", "got 0"});
  options.cameras = DomeRigOptions::MaxCameras() + 1;
  testing::ExpectInputError([&] { options.Check(); }, {"--cameras"});
  options = DomeRigOptions();
  options.width_px = 0;
  testing::ExpectInputError([&] { options.Check(); }, {"--width", "got 0"});
  options = DomeRigOptions();
  options.height_px = 0;
  testing::ExpectInputError([&] { options.Check(); }, {"--height", "got 0"});
}

}  // namespace
}  // namespace dome::synth

namespace dome::synth {
namespace {

// Stage 2 needs floor marks that every camera of the dome sees (seed §2.2): all of
// them project inside every paper camera's image, a mark's radius from the border.
TEST(DomeRig, EveryPaperCameraSeesEveryFloorMark) {
  for (const auto& cam : MakeDomeRig(DomeRigOptions())) {
    const auto& m = cam.rig.model;
    for (const auto& mark : FloorMarkPoints()) {
      Eigen::Vector2d px;
      ASSERT_TRUE(m.Project(mark.position_mm, &px));
      const double margin = 2.0 * kFloorMarkDotRadiusMm * m.focal_mm / m.sensor.dpx_mm() /
                            m.WorldToCamera(mark.position_mm).z();
      EXPECT_GT(px.x(), margin) << m.id << " mark " << mark.id;
      EXPECT_GT(px.y(), margin) << m.id << " mark " << mark.id;
      EXPECT_LT(px.x(), m.width_px - 1 - margin) << m.id << " mark " << mark.id;
      EXPECT_LT(px.y(), m.height_px - 1 - margin) << m.id << " mark " << mark.id;
    }
  }
}

}  // namespace
}  // namespace dome::synth
