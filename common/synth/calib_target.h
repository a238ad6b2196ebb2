// The calibration targets of the synthetic dome (seed §2.2 and §4.1: Tsai's two-stage
// calibration).
//
// Stage 1 (intrinsics): a 3D calibration object -- three orthogonal 800 mm square
// plates meeting at a corner, like the inside of a box -- whose white faces carry a
// 7 x 7 grid of black dots, 100 mm apart. Object frame: the corner at the origin, the
// plates' dotted faces on the planes z = 0, y = 0 and x = 0 (the plate bodies, 12 mm
// thick, lie on the negative side), dots at 100..700 mm. On each plate the dot
// nearest the corner is larger (the key dot) so a detector can tell the plates apart.
// Each camera sees the object from inside the corner, filling much of its view.
//
// Stage 2 (extrinsics): floor marks -- black dots on white pads -- in a 5 x 5 grid,
// 250 mm apart, centred on the dome's axis (world frame, z = 0), visible to every
// camera of the dome; the mark at (-500, -500) is the larger key mark. Around it, plain
// marks on three rings across the dome's floor (radius 1, 1.5 and 2 m, ~520 mm apart
// along a ring) that each camera sees in part: a grid 1 m across seen from ~3 m leaves
// a camera's rotation and sideways position trading off, marks over its whole view pin
// them. The grid labels the marks (calib/target.h: the plain marks are found from the
// pose it gives); on rings, the plain marks form no lattice with the grid's marks that
// a grid detector could take for the grid.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "schema/calib_json.h"

namespace dome::synth {

using schema::TargetPoint;  // the points as TAKE/calib/*/target.json holds them

// Stage-1 object.
inline constexpr double kPlateSizeMm = 800.0;
inline constexpr double kPlateThicknessMm = 12.0;
inline constexpr double kPlateDotPitchMm = 100.0;
inline constexpr int kPlateDotsPerSide = 7;  // dots at 100 .. 700 mm
inline constexpr double kPlateDotRadiusMm = 20.0;
inline constexpr double kPlateKeyDotRadiusMm = 30.0;

// Rotation (plate-local -> object frame) of plate 0, 1, 2. In plate-local
// coordinates the dotted face is z = 0 with dots at (x, y) = (100 i, 100 j),
// i, j = 1..7, and the plate body lies at z in [-thickness, 0].
Eigen::Matrix3d PlateRotation(int plate);
// The dots of the object, object frame (mm); id = 49 * plate + 7 * (j - 1) + (i - 1).
std::vector<TargetPoint> CalibObjectPoints();
// Albedo of a plate's face at plate-local (x, y), mm.
double CalibPlateAlbedo(double x_mm, double y_mm);

// Stage-2 floor marks.
inline constexpr int kFloorMarksPerSide = 5;
inline constexpr double kFloorMarkPitchMm = 250.0;
inline constexpr double kFloorMarkDotRadiusMm = 45.0;
inline constexpr double kFloorMarkKeyDotRadiusMm = 60.0;
inline constexpr double kFloorMarkPadRadiusMm = 110.0;

// Plain marks: kFloorRingMarks[k] marks on a ring of radius kFloorRingRadiusMm[k]
// about the axis, at angles (m + 1/2) 360 / count degrees from +x, m = 0, 1, ...
inline constexpr int kFloorRings = 3;
inline constexpr double kFloorRingRadiusMm[kFloorRings] = {1000.0, 1500.0, 2000.0};
inline constexpr int kFloorRingMarks[kFloorRings] = {12, 18, 24};

// The key-marked grid's marks, world frame (z = 0); id = 5 * row + column, x and y
// increasing.
std::vector<TargetPoint> FloorMarkPoints();
// The grid's marks, then the plain marks (ids 25, 26, ... ring by ring, angle
// increasing): the stage-2 target (TargetPoints.grid_points = 25).
std::vector<TargetPoint> AllFloorMarkPoints();
// Albedo of the floor with marks at world (x, y), given the plain floor's albedo
// there; returns floor_albedo away from the marks.
double FloorMarksAlbedo(double x_mm, double y_mm, double floor_albedo);

}  // namespace dome::synth
