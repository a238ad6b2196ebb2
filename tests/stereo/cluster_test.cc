#include "stereo/cluster.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "stereo/stereo_test_util.h"
#include "testing/expect_error.h"

namespace dome::stereo {
namespace {

geometry::Rig LineRig(int n) {
  geometry::Rig rig;
  for (int i = 0; i < n; ++i) {
    geometry::RigCamera c;
    c.model = testing::PlaneCamera("c" + std::to_string(i), 100.0 * i, 0);
    rig.cameras.push_back(c);
  }
  return rig;
}

TEST(ClusterTest, DerivedFromGeometryNearestFirst) {
  const geometry::Rig rig = LineRig(6);
  ClusterOptions opt;
  opt.max_neighbours = 3;
  const auto c = SelectCluster(rig, "c2", opt);
  ASSERT_EQ(c.size(), 3u);
  EXPECT_TRUE((c[0] == 1 || c[0] == 3) && (c[1] == 1 || c[1] == 3) && c[0] != c[1]);
  EXPECT_TRUE(c[2] == 0 || c[2] == 4);
}

TEST(ClusterTest, RigNeighboursWin) {
  geometry::Rig rig = LineRig(4);
  rig.cameras[0].neighbours = {"c3", "c2"};
  const auto c = SelectCluster(rig, "c0", {});
  EXPECT_EQ(c, (std::vector<int>{3, 2}));
}

TEST(ClusterTest, AxesFacingAwayAreNotNeighbours) {
  geometry::Rig rig = LineRig(2);
  // Turn c1 around (180 degrees about y): it looks the other way.
  rig.cameras[1].model.rotation = Eigen::Vector3d(-1, 1, -1).asDiagonal();
  dome::testing::ExpectInputError([&] { SelectCluster(rig, "c0", {}); },
                                  {"cluster", "c0", "no neighbours"});
}

// Rotation of `deg` degrees about the camera's y axis (down): the axis turns in x-z.
Eigen::Matrix3d TurnedAboutY(double deg) {
  return Eigen::AngleAxisd(deg * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
}

TEST(ClusterTest, SparseRigTakesTheNearestInAxisAngle) {
  // Axes 70, 100 and 150 degrees from c0's: none within the 60 degree default.
  geometry::Rig rig = LineRig(4);
  rig.cameras[1].model.rotation = TurnedAboutY(100);
  rig.cameras[2].model.rotation = TurnedAboutY(70);
  rig.cameras[3].model.rotation = TurnedAboutY(150);
  const auto c = SelectCluster(rig, "c0", {});
  // The two nearest in angle, nearest first; 150 degrees (beyond 135) is never used.
  EXPECT_EQ(c, (std::vector<int>{2, 1}));
  ClusterOptions one;
  one.max_neighbours = 1;
  EXPECT_EQ(SelectCluster(rig, "c0", one), (std::vector<int>{2}));
}

TEST(ClusterTest, MedianNearestAxisAngle) {
  // Axes at 0, 20 and 90 degrees: nearest others 20, 20 and 70 degrees away.
  geometry::Rig rig = LineRig(3);
  rig.cameras[1].model.rotation = TurnedAboutY(20);
  rig.cameras[2].model.rotation = TurnedAboutY(90);
  EXPECT_NEAR(MedianNearestAxisAngleDeg(rig), 20.0, 1e-9);
  rig.cameras[0].model.rotation = TurnedAboutY(-60);  // now 80, 20, 70: median 70
  EXPECT_NEAR(MedianNearestAxisAngleDeg(rig), 70.0, 1e-9);
  EXPECT_EQ(MedianNearestAxisAngleDeg(LineRig(1)), 0.0);
}

TEST(ClusterTest, BadInputs) {
  dome::testing::ExpectInputError([&] { SelectCluster(LineRig(3), "c9", {}); },
                                  {"--camera", "'c9'", "not in the rig"});
  dome::testing::ExpectInputError([&] { SelectCluster(LineRig(1), "c0", {}); },
                                  {"cluster", "one camera"});
  ClusterOptions bad;
  bad.max_neighbours = 0;
  dome::testing::ExpectInputError([&] { SelectCluster(LineRig(3), "c0", bad); },
                                  {"max_neighbours"});
}

}  // namespace
}  // namespace dome::stereo
