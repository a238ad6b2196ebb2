// The scenes the synthetic dome renders.
//
//  * The dome scene at time t (world frame, mm): a 12 m x 12 m textured floor (z = 0)
//    inside four 4 m high textured walls at +-6 m -- the distant background, outside
//    the seed's 6 m fusion volume -- open to the sky above, and the batter
//    (synth/batter.h) at the centre. Faces buried inside another body part are removed.
//  * The stage-2 calibration scene: the same room, no person, the floor marks drawn on
//    the floor (synth/calib_target.h).
//  * The stage-1 bench scene, in one camera's frame (x right, y down, z forward): the
//    calibration object placed by `object_to_camera`, and a plain backdrop 3 m away.
#pragma once

#include <Eigen/Core>

#include "synth/scene_mesh.h"

namespace dome::synth {

inline constexpr double kRoomHalfSizeMm = 6000.0;
inline constexpr double kWallHeightMm = 4000.0;

SceneMesh BuildRoom(bool floor_marks);
SceneMesh BuildDomeScene(double time_s);
SceneMesh BuildFloorMarkScene();
SceneMesh BuildBenchScene(const Eigen::Matrix3d& object_to_camera_rotation,
                          const Eigen::Vector3d& object_to_camera_translation_mm);

}  // namespace dome::synth
