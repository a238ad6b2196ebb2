// The articulated person of the synthetic dome: a batter swinging a baseball bat, as
// in the seed's sequence (§4.1, Figure 8).
//
// The body is a skeleton of rigid parts (pelvis, torso, shoulder girdle, neck, head,
// upper arms, forearms, hands, thighs, shins, feet) tessellated from capsules,
// ellipsoids and boxes, plus the bat: a capsule 850 mm long and 70 mm thick (so 20 mm
// voxels recover it poorly and 10 mm voxels well, seed §4.5).
//
// Motion (world frame, mm, z up; the batter stands at the dome's centre facing +y,
// his right towards +x): the swing angle alpha -- the bat's heading about the vertical,
// 0 = straight ahead, positive = counter-clockwise seen from above -- follows a
// minimum-jerk profile (smooth position, velocity and acceleration; Flash & Hogan
// 1985) from -130 deg (cocked over the right shoulder) to +160 deg (wrapped round the
// left) between t = -0.3 s and t = 1.9 s. Over the seed's 11 instants at 6 Hz
// (t = 0 .. 5/3 s) the bat sweeps 14-41 deg between instants and up to ~4 deg (80 mm
// at the tip, a tip speed of ~5 m/s: a calm swing) between the two fields of a frame. Torso, pelvis
// and head turn with fractions of alpha; the hands hold the bat (two-bone inverse kinematics for
// the arms, with elbows down); the feet stay planted (inverse kinematics for the legs) while the
// weight shifts from the back foot to the front foot.
#pragma once

#include <Eigen/Core>

#include "synth/scene_mesh.h"

namespace dome::synth {

// Joint positions of the posed skeleton (world, mm) for tests and summaries.
struct BatterPose {
  double time_s = 0.0;
  double swing_deg = 0.0;       // alpha
  Eigen::Vector3d bat_knob_mm;  // the bat's end at the hands
  Eigen::Vector3d bat_dir;      // unit, from the knob to the barrel end
  double bat_length_mm = 850.0;
  double bat_radius_mm = 35.0;
  Eigen::Vector3d grip_mm[2];      // where the left (0) and right (1) hands should be
  Eigen::Vector3d shoulder_mm[2];  // left, right
  Eigen::Vector3d elbow_mm[2];
  Eigen::Vector3d hand_mm[2];  // where the arms actually put the hands
  Eigen::Vector3d hip_mm[2];
  Eigen::Vector3d knee_mm[2];
  Eigen::Vector3d ankle_mm[2];  // where the legs actually put the ankles
  Eigen::Vector3d ankle_target_mm[2];
  Eigen::Vector3d head_centre_mm;
  // Bone lengths (constant by construction; tests check the posed skeleton keeps them).
  static constexpr double kUpperArmMm = 300.0;
  static constexpr double kForearmMm = 320.0;  // elbow to the centre of the grip
  static constexpr double kThighMm = 440.0;
  static constexpr double kShinMm = 430.0;
};

BatterPose PoseBatter(double time_s);

// Adds the posed batter and bat to `mesh` (parts flagged on_person).
void AddBatter(const BatterPose& pose, SceneMesh* mesh);

}  // namespace dome::synth
