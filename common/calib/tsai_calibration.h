// Tsai's camera calibration (R. Tsai, "A versatile camera calibration technique for
// high-accuracy 3D machine vision metrology using off-the-shelf TV cameras and
// lenses", IEEE J. Robotics and Automation 3(4), 1987; R. Willson's implementation):
// the closed-form initialisation from the radial alignment constraint, for
// non-coplanar and coplanar points, followed by a Levenberg-Marquardt refinement of
// every free parameter (Eigen's unsupported LevenbergMarquardt module).
//
// Frames, units and the 11 parameters are those of geometry/tsai_camera.h: the pose
// maps the target frame (world or object, mm) to the camera frame, camera = R p + t;
// image points are *distorted* pixels (pixel centres at integers).
//
// Observations may come from several views of one camera (each view its own pose,
// e.g. the stage-1 object and the stage-2 floor marks, or the images of a chessboard):
// RefineCamera shares the intrinsics across views.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "geometry/tsai_camera.h"

namespace dome::calib {

// One target point and where it appears in an image.
struct Correspondence {
  int id = 0;
  Eigen::Vector3d target_mm = Eigen::Vector3d::Zero();  // target frame, mm
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();      // distorted pixel
  // A detected dot marker (radius > 0): its plane's unit normal (target frame) and
  // radius, mm, and its centroid as detected, px. The centroid of a dot's image is
  // not the image of its centre; CorrectDotCentroids sets `pixel` from these.
  Eigen::Vector3d marker_normal = Eigen::Vector3d::Zero();
  double marker_radius_mm = 0.0;
  Eigen::Vector2d detected_px = Eigen::Vector2d::Zero();
};

// What is known of a camera before calibration: its id, image size and sensor
// constants (Tsai's "known" parameters), and starting guesses where a stage has them.
struct CameraPrior {
  std::string id;
  int width_px = 0;
  int height_px = 0;
  geometry::TsaiSensor sensor;

  // The camera of these constants with the given intrinsics, kappa1 = 0, pose identity.
  geometry::TsaiCamera Camera(double focal_mm, double cx_px, double cy_px, double sx) const {
    geometry::TsaiCamera c;
    c.id = id;
    c.width_px = width_px;
    c.height_px = height_px;
    c.sensor = sensor;
    c.focal_mm = focal_mm;
    c.cx_px = cx_px;
    c.cy_px = cy_px;
    c.sx = sx;
    return c;
  }
};

struct TsaiInitOptions {
  // Non-coplanar points must span a volume: the smallest singular value of the
  // centred point cloud over its largest must reach this (unitless).
  double min_volume_ratio = 0.05;
  int min_points_noncoplanar = 11;  // points (Tsai needs >= 7; margin for noise)
  int min_points_coplanar = 8;      // points (Tsai needs >= 5)
  void Check() const;
};

// Tsai's closed-form estimate from non-coplanar points, with the image centre at
// (cx_px, cy_px) and kappa1 = 0: R, t, focal length and sx. `where` names the view in
// errors. Throws core::InputError for too few points, points without volume, points
// behind the camera, or a degenerate linear system.
geometry::TsaiCamera TsaiInitNonCoplanar(const CameraPrior& prior, double cx_px, double cy_px,
                                         const std::vector<Correspondence>& points,
                                         const TsaiInitOptions& options, const std::string& where);

// Tsai's closed-form estimate from coplanar points (target z = 0), with sx, the image
// centre and kappa1 taken from `intrinsics` (its pose is ignored); the image points are
// undistorted with intrinsics.kappa1 first, so known distortion is exact. Returns R, t
// and f (focal_mm is estimated unless `fix_focal`, then kept). Throws as above; also
// when the points are not on z = 0.
geometry::TsaiCamera TsaiInitCoplanar(const geometry::TsaiCamera& intrinsics,
                                      const std::vector<Correspondence>& points, bool fix_focal,
                                      const TsaiInitOptions& options, const std::string& where);

// One view of a camera: its correspondences and its target -> camera pose.
struct View {
  std::string name;  // for messages and reports
  std::vector<Correspondence> points;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
};

struct RefineOptions {
  bool refine_focal = true;
  bool refine_kappa1 = true;
  bool refine_centre = true;
  bool refine_sx = true;
  bool refine_poses = true;
  int max_function_evaluations = 4000;  // LM function evaluations (each a full residual)
  void Check() const;
};

// Standard deviations (1 sigma, from the Gauss-Newton covariance at the optimum scaled
// by the residual variance) of the parameters refined; 0 where a parameter was fixed.
struct ParameterSigma {
  double focal_mm = 0.0;
  double kappa1_per_mm2 = 0.0;
  double cx_px = 0.0;
  double cy_px = 0.0;
  double sx = 0.0;
  // Of the last view's pose: rotation (small-angle vector, degrees) and translation, mm.
  Eigen::Vector3d rotation_deg = Eigen::Vector3d::Zero();
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
};

struct RefineSummary {
  int iterations = 0;
  int function_evaluations = 0;
  double initial_rms_px = 0.0;
  double final_rms_px = 0.0;
  int parameters = 0;
  int residuals = 0;
  ParameterSigma sigma;
  bool converged = false;
  std::string BriefReport() const;
};

// Levenberg-Marquardt over the intrinsics of `camera` (the ones the options free) and
// the poses of `views` (rotations updated by a rotation vector, so no gimbal lock).
// The camera's own pose field is left as it is; the views carry the poses. Throws
// core::InputError when there are fewer residuals than parameters.
RefineSummary RefineCamera(geometry::TsaiCamera* camera, std::vector<View>* views,
                           const RefineOptions& options, const std::string& where);

// Where the centroid of a dot's image lies relative to the image of its centre, px:
// the dot (centre, unit normal and radius in the target frame, mm) imaged by
// (intrinsics, view pose) -- perspective and lens distortion shift the centroid of
// the imaged outline towards the dot's nearer, larger side. Zero when the dot is not
// wholly in front of the camera.
Eigen::Vector2d DotCentroidOffsetPx(const geometry::TsaiCamera& intrinsics, const View& view,
                                    const Eigen::Vector3d& centre_mm, const Eigen::Vector3d& normal,
                                    double radius_mm);

// For every dot marker of `view` (marker_radius_mm > 0): pixel = detected_px minus
// its centroid offset under (intrinsics, view pose), so that the refinement fits the
// images of the dot centres.
void CorrectDotCentroids(const geometry::TsaiCamera& intrinsics, View* view);

// Reprojection error of one correspondence under (camera intrinsics, view pose), px;
// infinity when the point is behind the camera.
double ReprojectionErrorPx(const geometry::TsaiCamera& intrinsics, const View& view,
                           const Correspondence& c);

}  // namespace dome::calib
