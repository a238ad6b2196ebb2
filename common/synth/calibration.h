// Calibration shots of the synthetic dome and their truth (synth/calib_target.h).
//
// Stage 1: each camera, on the calibration bench, looks into the corner of the 3D
// calibration object from about the (1, 1, 1) direction, with a per-camera jitter of
// the viewing direction and roll drawn from a fixed stream; the distance is chosen
// so the object spans ~90% of the image's width or height. The object is then moved
// (the seed moved its object) to kStage1Poses - 1 further poses, each showing it
// nearer one corner of the image so that the dots reach the image corners, where
// the radial distortion kappa1 is largest and observable.
// Stage 2: each camera, in place on the dome, looks at the floor marks.
// True image points are the exact (distorted) projections of the marker centres
// that are visible (the ray through the projection reaches the marker) and lie at
// least one marker radius inside the image.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "geometry/tsai_camera.h"
#include "synth/calib_target.h"
#include "synth/ray_caster.h"

namespace dome::synth {

using schema::ImagePoint;  // where a target point is seen, as a CalibView file holds it

// Stage-1 images per camera: pose 0 (the object centred) and one pose per image
// corner.
inline constexpr int kStage1Poses = 5;

// Pose (object -> camera) of the stage-1 object for camera `camera_index`, whose
// intrinsics are those of `camera` (its pose is ignored); `pose` in [0, kStage1Poses).
void Stage1Pose(const geometry::TsaiCamera& camera, int camera_index, int pose,
                Eigen::Matrix3d* object_to_camera_rotation,
                Eigen::Vector3d* object_to_camera_translation_mm);
// Pose 0.
inline void Stage1Pose(const geometry::TsaiCamera& camera, int camera_index,
                       Eigen::Matrix3d* object_to_camera_rotation,
                       Eigen::Vector3d* object_to_camera_translation_mm) {
  Stage1Pose(camera, camera_index, 0, object_to_camera_rotation, object_to_camera_translation_mm);
}

// True image points of `points` (given in the frame of the scene `caster` holds),
// seen by `camera` whose pose maps that frame to the camera.
std::vector<ImagePoint> TrueImagePoints(const geometry::TsaiCamera& camera,
                                        const std::vector<TargetPoint>& points,
                                        double marker_radius_mm, const RayCaster& caster);

}  // namespace dome::synth
