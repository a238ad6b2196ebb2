#include "synth/batter.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace dome::synth {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

constexpr double kDeg = M_PI / 180.0;

// Swing schedule (see the header).
constexpr double kSwingStartS = -0.3;
constexpr double kSwingEndS = 1.9;
constexpr double kAlphaStartDeg = -130.0;
constexpr double kAlphaEndDeg = 160.0;
constexpr double kAlphaWindupDeg = 145.0;  // |alpha| at which the windup is complete

// Body dimensions, mm.
constexpr double kPelvisHeight = 930.0;
constexpr double kWaistAbovePelvis = 90.0;
constexpr double kLeanDeg = 12.0;
constexpr double kShoulderHalfWidth = 190.0;
constexpr double kShoulderHeight = 410.0;  // above the waist, chest frame
constexpr double kHipHalfWidth = 95.0;
constexpr double kHipBelowPelvis = 70.0;
constexpr double kAnkleHeight = 95.0;
constexpr double kFootHalfSpread = 330.0;

Matrix3d Rz(double a) {
  Matrix3d r;
  r << std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1;
  return r;
}
Matrix3d Rx(double a) {
  Matrix3d r;
  r << 1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a);
  return r;
}

// Heading on the floor plane: 0 = +y, positive = counter-clockwise from above.
Vector3d Heading(double a) { return {-std::sin(a), std::cos(a), 0.0}; }

// A unit vector perpendicular to u, as close as possible to `reference`.
Vector3d Perpendicular(const Vector3d& u, const Vector3d& reference) {
  Vector3d p = reference - reference.dot(u) * u;
  if (p.norm() < 1e-6) {
    const Vector3d other = std::abs(u.x()) < 0.9 ? Vector3d::UnitX() : Vector3d::UnitY();
    p = other - other.dot(u) * u;
  }
  return p.normalized();
}

// Rotation whose z axis is `axis` and whose x axis is as close as possible to
// `reference` (columns: the local axes in the world).
Matrix3d FrameAlong(const Vector3d& axis, const Vector3d& reference) {
  const Vector3d z = axis.normalized();
  const Vector3d x = Perpendicular(z, reference);
  Matrix3d r;
  r.col(0) = x;
  r.col(1) = z.cross(x);
  r.col(2) = z;
  return r;
}

// Two-bone inverse kinematics: root -> joint (length l1) -> end (length l2) reaching
// for `target`, the joint bending towards `pole`. The end is clamped to the reachable
// shell when the target is too far or too near.
void TwoBoneIk(const Vector3d& root, const Vector3d& target, double l1, double l2,
               const Vector3d& pole, Vector3d* joint, Vector3d* end) {
  const Vector3d d = target - root;
  const double dist = std::clamp(d.norm(), std::abs(l1 - l2) + 1e-6, l1 + l2 - 1e-6);
  const Vector3d u = d.normalized();
  const double cos_a = (l1 * l1 + dist * dist - l2 * l2) / (2.0 * l1 * dist);
  const double a = std::acos(std::clamp(cos_a, -1.0, 1.0));
  const Vector3d p = Perpendicular(u, pole);
  *joint = root + l1 * (std::cos(a) * u + std::sin(a) * p);
  *end = root + dist * u;
}

double MinimumJerk(double sigma) {
  sigma = std::clamp(sigma, 0.0, 1.0);
  return sigma * sigma * sigma * (10.0 - 15.0 * sigma + 6.0 * sigma * sigma);
}

struct Frames {
  Vector3d pelvis_centre;
  Matrix3d pelvis_rotation;
  Vector3d waist;
  Matrix3d chest_rotation;
  Matrix3d head_rotation;
  double windup;
};

Frames BodyFrames(double time_s, double* alpha_deg) {
  const double s = MinimumJerk((time_s - kSwingStartS) / (kSwingEndS - kSwingStartS));
  const double alpha = kAlphaStartDeg + (kAlphaEndDeg - kAlphaStartDeg) * s;
  *alpha_deg = alpha;
  Frames f;
  // Windup: 0 at contact (alpha = 0), 1 at |alpha| = kAlphaWindupDeg, growing smoothly
  // (and slowly) beyond, so the motion has no kink.
  const double x2 = (alpha / kAlphaWindupDeg) * (alpha / kAlphaWindupDeg);
  f.windup = 1.3 * x2 / (1.0 + 0.3 * x2);
  // Weight shifts from the back (right, +x) foot to the front (left) foot; the batter
  // crouches a little through contact.
  f.pelvis_centre = Vector3d(40.0 - 80.0 * s, 0.0, kPelvisHeight - 20.0 * (1.0 - f.windup));
  f.pelvis_rotation = Rz(0.3 * alpha * kDeg);
  f.waist = f.pelvis_centre + Vector3d(0, 0, kWaistAbovePelvis);
  f.chest_rotation = Rz(0.55 * alpha * kDeg) * Rx(-kLeanDeg * kDeg);
  f.head_rotation = Rz(0.12 * alpha * kDeg) * Rx(-6.0 * kDeg);
  return f;
}

Vector3d AnkleTarget(int side) {
  const double sign = side == 0 ? -1.0 : 1.0;
  return {sign * kFootHalfSpread, -sign * 20.0, kAnkleHeight};
}

}  // namespace

BatterPose PoseBatter(double time_s) {
  BatterPose pose;
  pose.time_s = time_s;
  double alpha_deg = 0.0;
  const Frames f = BodyFrames(time_s, &alpha_deg);
  pose.swing_deg = alpha_deg;
  const double alpha = alpha_deg * kDeg;
  const double beta = (10.0 + 52.0 * f.windup) * kDeg;
  pose.bat_dir = std::cos(beta) * Heading(alpha) + std::sin(beta) * Vector3d::UnitZ();
  // The lead (left) hand circles the body ahead of the chest, higher at the windup.
  const Vector3d lead = Vector3d(0.5 * f.pelvis_centre.x(), 0.0, 1130.0) +
                        330.0 * Heading(alpha - 15.0 * kDeg) + Vector3d(0, 0, 260.0 * f.windup);
  pose.grip_mm[0] = lead;
  pose.grip_mm[1] = lead + 95.0 * pose.bat_dir;
  pose.bat_knob_mm = lead - 55.0 * pose.bat_dir;
  for (int side = 0; side < 2; ++side) {
    const double sign = side == 0 ? -1.0 : 1.0;
    pose.shoulder_mm[side] =
        f.waist + f.chest_rotation * Vector3d(sign * kShoulderHalfWidth, -10.0, kShoulderHeight);
    const Vector3d elbow_pole =
        f.chest_rotation * Vector3d(0.45 * sign, -0.2, 0.0) - Vector3d::UnitZ();
    TwoBoneIk(pose.shoulder_mm[side], pose.grip_mm[side], BatterPose::kUpperArmMm,
              BatterPose::kForearmMm, elbow_pole, &pose.elbow_mm[side], &pose.hand_mm[side]);
    pose.hip_mm[side] =
        f.pelvis_centre + f.pelvis_rotation * Vector3d(sign * kHipHalfWidth, 0, -kHipBelowPelvis);
    pose.ankle_target_mm[side] = AnkleTarget(side);
    const Vector3d knee_pole = f.pelvis_rotation * Vector3d(0.25 * sign, 1.0, 0.0);
    TwoBoneIk(pose.hip_mm[side], pose.ankle_target_mm[side], BatterPose::kThighMm,
              BatterPose::kShinMm, knee_pole, &pose.knee_mm[side], &pose.ankle_mm[side]);
  }
  pose.head_centre_mm = f.waist + f.chest_rotation * Vector3d(0, 10.0, 560.0) +
                        f.head_rotation * Vector3d(0, 0, 105.0);
  return pose;
}

void AddBatter(const BatterPose& pose, SceneMesh* mesh) {
  double alpha_deg = 0.0;
  const Frames f = BodyFrames(pose.time_s, &alpha_deg);
  constexpr int kLimbSegments = 20, kLimbCapRings = 5;
  constexpr int kBodySegments = 28, kBodyRings = 14;

  auto add = [&](const char* name, Material material, const Matrix3d& rotation,
                 const Vector3d& translation, const LocalMesh& local, const Solid& solid) {
    Part part;
    part.name = name;
    part.material = material;
    part.rotation = rotation;
    part.translation_mm = translation;
    part.on_person = true;
    part.solid = solid;
    mesh->AddPart(part, local);
  };
  // Capsule from a to b with radii ra, rb; its texture frame's x follows `reference`.
  auto capsule = [&](const char* name, Material material, const Vector3d& a, const Vector3d& b,
                     double ra, double rb, const Vector3d& reference, int segments) {
    const double length = (b - a).norm();
    add(name, material, FrameAlong(b - a, reference), a,
        CapsuleMesh(length, ra, rb, segments, kLimbCapRings),
        CapsuleSolid(length, ra, rb, segments, kLimbCapRings));
  };
  auto ellipsoid = [&](const char* name, Material material, const Matrix3d& rotation,
                       const Vector3d& centre, const Vector3d& semi, int segments, int rings) {
    add(name, material, rotation, centre, EllipsoidMesh(semi, segments, rings),
        EllipsoidSolid(semi, segments, rings));
  };

  // Trunk.
  ellipsoid("pelvis", Material::kPants, f.pelvis_rotation, f.pelvis_centre, Vector3d(175, 115, 125),
            kBodySegments, kBodyRings);
  ellipsoid("torso", Material::kShirt, f.chest_rotation,
            f.waist + f.chest_rotation * Vector3d(0, 0, 240), Vector3d(170, 110, 270),
            kBodySegments, kBodyRings);
  const Vector3d chest_x = f.chest_rotation.col(0);
  capsule("shoulders", Material::kShirt, f.waist + f.chest_rotation * Vector3d(-150, -10, 400),
          f.waist + f.chest_rotation * Vector3d(150, -10, 400), 60, 60, f.chest_rotation.col(2),
          kLimbSegments);
  const Vector3d neck_base = f.waist + f.chest_rotation * Vector3d(0, 0, 450);
  const Vector3d neck_top = f.waist + f.chest_rotation * Vector3d(0, 10, 560);
  capsule("neck", Material::kSkin, neck_base, neck_top, 52, 48, chest_x, kLimbSegments);
  ellipsoid("head", Material::kHead, f.head_rotation, pose.head_centre_mm, Vector3d(78, 95, 112),
            kBodySegments, kBodyRings);

  // Arms and hands.
  const char* upper_names[2] = {"left upper arm", "right upper arm"};
  const char* fore_names[2] = {"left forearm", "right forearm"};
  const char* hand_names[2] = {"left hand", "right hand"};
  for (int side = 0; side < 2; ++side) {
    capsule(upper_names[side], Material::kShirt, pose.shoulder_mm[side], pose.elbow_mm[side], 50,
            42, chest_x, kLimbSegments);
    const Vector3d fore_dir = (pose.hand_mm[side] - pose.elbow_mm[side]).normalized();
    capsule(fore_names[side], Material::kSkin, pose.elbow_mm[side],
            pose.elbow_mm[side] + 250.0 * fore_dir, 40, 32, chest_x, kLimbSegments);
    ellipsoid(hand_names[side], Material::kSkin, FrameAlong(fore_dir, pose.bat_dir),
              pose.hand_mm[side], Vector3d(48, 50, 55), 16, 8);
  }

  // Legs and feet.
  const char* thigh_names[2] = {"left thigh", "right thigh"};
  const char* shin_names[2] = {"left shin", "right shin"};
  const char* foot_names[2] = {"left foot", "right foot"};
  const Vector3d pelvis_y = f.pelvis_rotation.col(1);
  for (int side = 0; side < 2; ++side) {
    capsule(thigh_names[side], Material::kPants, pose.hip_mm[side], pose.knee_mm[side], 80, 58,
            pelvis_y, kLimbSegments);
    capsule(shin_names[side], Material::kPants, pose.knee_mm[side], pose.ankle_mm[side], 55, 42,
            pelvis_y, kLimbSegments);
    const double sign = side == 0 ? -1.0 : 1.0;
    const Matrix3d foot_rotation = Rz(-sign * 12.0 * kDeg);
    const Vector3d foot_size(100, 250, 85);
    add(foot_names[side], Material::kShoe, foot_rotation,
        pose.ankle_target_mm[side] + foot_rotation * Vector3d(0, 60, -50), BoxMesh(foot_size),
        BoxSolid(foot_size));
  }

  // The bat: its local z runs from the start of the straight part (one radius in from
  // the knob) towards the barrel end.
  const double r = pose.bat_radius_mm;
  capsule("bat", Material::kBat, pose.bat_knob_mm + r * pose.bat_dir,
          pose.bat_knob_mm + (pose.bat_length_mm - r) * pose.bat_dir, r, r, Vector3d::UnitZ(), 24);
}

}  // namespace dome::synth
