#include "synth/batter.h"

#include <gtest/gtest.h>

#include <cmath>

#include "synth/synth.h"

namespace dome::synth {
namespace {

using Eigen::Vector3d;

double AngleDeg(const Vector3d& a, const Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / M_PI;
}

// Over the seed's 11 instants (and a little beyond) the skeleton keeps its bone
// lengths, the hands hold the bat, the feet stay planted and nothing goes through
// the floor.
TEST(Batter, SkeletonIsConsistentThroughTheSwing) {
  for (double t = -0.1; t <= InstantTimeS(10) + 0.1; t += 1.0 / 240.0) {
    const BatterPose p = PoseBatter(t);
    for (int side = 0; side < 2; ++side) {
      EXPECT_NEAR((p.elbow_mm[side] - p.shoulder_mm[side]).norm(), BatterPose::kUpperArmMm, 1e-6);
      EXPECT_NEAR((p.hand_mm[side] - p.elbow_mm[side]).norm(), BatterPose::kForearmMm, 1e-6);
      EXPECT_NEAR((p.knee_mm[side] - p.hip_mm[side]).norm(), BatterPose::kThighMm, 1e-6);
      EXPECT_NEAR((p.ankle_mm[side] - p.knee_mm[side]).norm(), BatterPose::kShinMm, 1e-6);
      // Reachable targets: the hands are on the bat's handle, the ankles over the feet.
      EXPECT_LT((p.hand_mm[side] - p.grip_mm[side]).norm(), 0.01) << "t " << t << " side " << side;
      EXPECT_LT((p.ankle_mm[side] - p.ankle_target_mm[side]).norm(), 0.01) << "t " << t;
      // Elbows below the shoulders, knees in front of the hips' line and above the ankles.
      EXPECT_LT(p.elbow_mm[side].z(), p.shoulder_mm[side].z() + 50.0) << "t " << t;
      EXPECT_GT(p.knee_mm[side].z(), p.ankle_mm[side].z() + 200.0);
    }
    // The bat clears the floor; the head is on top.
    const Vector3d tip = p.bat_knob_mm + p.bat_length_mm * p.bat_dir;
    EXPECT_GT(std::min(tip.z(), p.bat_knob_mm.z()) - p.bat_radius_mm, 100.0) << "t " << t;
    EXPECT_GT(p.head_centre_mm.z(), 1600.0);
    EXPECT_LT(p.head_centre_mm.z(), 1750.0);
    EXPECT_NEAR(p.bat_dir.norm(), 1.0, 1e-12);
  }
}

// The bat sweeps a large arc between instants (seed: motion at 6 Hz), moves visibly
// but plausibly between the two fields of a frame, and its motion is smooth.
TEST(Batter, SwingIsLargeBetweenInstantsAndSmooth) {
  double largest_step = 0.0;
  double total = 0.0;
  for (int k = 0; k < 10; ++k) {
    const double step =
        PoseBatter(InstantTimeS(k + 1)).swing_deg - PoseBatter(InstantTimeS(k)).swing_deg;
    EXPECT_GT(step, 0.0);
    largest_step = std::max(largest_step, step);
    total += step;
  }
  EXPECT_GT(largest_step, 40.0);
  EXPECT_GT(total, 200.0);
  double max_tip_speed = 0.0, max_accel = 0.0, previous_speed = 0.0;
  const double dt = 1.0 / 600.0;
  for (double t = 0.0; t <= InstantTimeS(10); t += dt) {
    const BatterPose a = PoseBatter(t), b = PoseBatter(t + dt);
    const Vector3d ta = a.bat_knob_mm + a.bat_length_mm * a.bat_dir;
    const Vector3d tb = b.bat_knob_mm + b.bat_length_mm * b.bat_dir;
    const double speed = (tb - ta).norm() / dt / 1000.0;  // m/s
    max_tip_speed = std::max(max_tip_speed, speed);
    if (t > 0) max_accel = std::max(max_accel, std::abs(speed - previous_speed) / dt);
    previous_speed = speed;
  }
  EXPECT_GT(max_tip_speed, 3.0);   // between fields (1/60 s) the tip moves > 50 mm
  EXPECT_LT(max_tip_speed, 15.0);  // a real swing peaks near 30 m/s; this is a calm one
  EXPECT_LT(max_accel, 200.0);     // m/s^2: no jerks
  // Between the fields of the middle instant the bat turns a few degrees.
  const BatterPose f1 = PoseBatter(InstantTimeS(5)),
                   f2 = PoseBatter(InstantTimeS(5) + kFieldDelayS);
  const double field_turn = AngleDeg(f1.bat_dir, f2.bat_dir);
  EXPECT_GT(field_turn, 2.0);
  EXPECT_LT(field_turn, 10.0);
}

TEST(Batter, MeshIsOnThePersonAndHoldsTheBat) {
  SceneMesh mesh;
  const BatterPose pose = PoseBatter(0.8);
  AddBatter(pose, &mesh);
  EXPECT_GT(mesh.parts.size(), 15u);
  for (const auto& part : mesh.parts) EXPECT_TRUE(part.on_person) << part.name;
  // The bat is 850 mm long and 70 mm thick: its vertices lie within the capsule.
  int bat = -1;
  for (size_t i = 0; i < mesh.parts.size(); ++i) {
    if (mesh.parts[i].name == "bat") bat = static_cast<int>(i);
  }
  ASSERT_GE(bat, 0);
  double lo = 1e9, hi = -1e9, radial = 0;
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    if (mesh.face_part[f] != bat) continue;
    for (int k = 0; k < 3; ++k) {
      const Vector3d v = mesh.vertices[mesh.faces[f][k]].cast<double>() - pose.bat_knob_mm;
      const double along = v.dot(pose.bat_dir);
      lo = std::min(lo, along);
      hi = std::max(hi, along);
      radial = std::max(radial, (v - along * pose.bat_dir).norm());
    }
  }
  EXPECT_NEAR(lo, 0.0, 0.01);
  EXPECT_NEAR(hi, 850.0, 0.01);
  EXPECT_NEAR(radial, 35.0, 0.01);
}

}  // namespace
}  // namespace dome::synth
