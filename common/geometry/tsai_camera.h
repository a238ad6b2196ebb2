// Tsai's 11-parameter camera model (R. Tsai, "A versatile camera calibration
// technique...", IEEE J. Robotics and Automation 1987; R. Willson's implementation).
//
// Frames and units
//  * World: right-handed, millimetres.
//  * Camera: X right, Y down, Z forward along the optical axis, millimetres.
//    camera = rotation * world + translation_mm   (the pose maps world -> camera).
//  * Sensor plane: millimetres, origin at the principal point, same axes as the camera.
//      undistorted Xu = focal_mm * Xc / Zc,  Yu = focal_mm * Yc / Zc
//      Tsai's radial model goes from distorted to undistorted:
//      Xu = Xd * (1 + kappa1 * r^2), Yu = Yd * (1 + kappa1 * r^2), r^2 = Xd^2 + Yd^2.
//  * Pixels (Tsai's "frame buffer" coordinates): x right, y down, integer values at
//    pixel centres, (0, 0) the centre of the top-left pixel.
//      Xf = sx * Xd / dpx + cx_px,  Yf = Yd / dpy + cy_px,  dpx = dx * ncx / nfx.
//
// The 11 parameters: 3 rotation, 3 translation, focal_mm, kappa1, cx_px, cy_px, sx.
// The sensor constants (ncx, nfx, dx, dy, dpx, dpy) are known, not estimated.
#pragma once

#include <Eigen/Core>
#include <string>

namespace dome::geometry {

// Known constants of the sensor and frame grabber (Tsai's camera "Geometry").
struct TsaiSensor {
  double ncx = 1.0;    // sensor elements in x (count)
  double nfx = 1.0;    // pixels in a frame-grabber line (count)
  double dx_mm = 0.01;  // centre-to-centre distance of sensor elements in x, in mm
  double dy_mm = 0.01;  // centre-to-centre distance of sensor lines in y, in mm
  // Effective pixel pitch in x of the digitized image, in mm: dx * ncx / nfx.
  double dpx_mm() const { return dx_mm * ncx / nfx; }
  // Effective pixel pitch in y, in mm (Tsai: dpy = dy).
  double dpy_mm() const { return dy_mm; }
};

struct TsaiCamera {
  std::string id;           // camera identifier, unique within a rig
  int width_px = 0;         // image width, in pixels
  int height_px = 0;        // image height, in pixels
  TsaiSensor sensor;
  double focal_mm = 0.0;           // effective focal length, in mm
  double kappa1_per_mm2 = 0.0;     // radial distortion, in 1/mm^2 (sensor plane)
  double cx_px = 0.0;              // image centre x (principal point), in pixels
  double cy_px = 0.0;              // image centre y, in pixels
  double sx = 1.0;                 // horizontal scale factor (dimensionless)
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // world -> camera
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();  // world -> camera, in mm

  // Throws core::InputError naming `where` and the offending field when a value is
  // not finite, a size or pitch is not positive, or the rotation is not a proper
  // rotation (orthonormal to 1e-6, determinant +1).
  void Check(const std::string& where) const;

  // Camera centre in world coordinates, in mm.
  Eigen::Vector3d CentreWorld() const;
  // World point (mm) -> camera frame (mm).
  Eigen::Vector3d WorldToCamera(const Eigen::Vector3d& world_mm) const;

  // World point -> distorted pixel (what the real camera sees). Returns false, and
  // leaves *pixel untouched, when the point is not in front of the camera (Zc <= 0).
  bool Project(const Eigen::Vector3d& world_mm, Eigen::Vector2d* pixel) const;
  // Camera-frame point -> distorted pixel; false when Zc <= 0.
  bool ProjectCamera(const Eigen::Vector3d& camera_mm, Eigen::Vector2d* pixel) const;

  // Distorted pixel -> unit ray direction in world coordinates; the ray starts at
  // CentreWorld(). Exact (uses the closed-form distorted->undistorted direction).
  Eigen::Vector3d BackProject(const Eigen::Vector2d& pixel) const;
  // Distorted pixel -> the world point on its ray at camera depth Zc = depth_mm.
  Eigen::Vector3d BackProjectAtDepth(const Eigen::Vector2d& pixel, double depth_mm) const;

  // Pixel of the ideal (kappa1 = 0) camera with the same f, sx, centre and sensor.
  // UndistortPixel is exact (closed form); DistortPixel inverts the cubic exactly
  // (Cardano, as Willson's code does) and round-trips to machine precision.
  Eigen::Vector2d UndistortPixel(const Eigen::Vector2d& distorted) const;
  Eigen::Vector2d DistortPixel(const Eigen::Vector2d& undistorted) const;

  // Sensor-plane helpers (mm).
  Eigen::Vector2d PixelToSensor(const Eigen::Vector2d& pixel) const;
  Eigen::Vector2d SensorToPixel(const Eigen::Vector2d& sensor_mm) const;
  // Ideal pinhole intrinsics of the undistorted camera (see pinhole.h):
  //   fx = focal * sx / dpx, fy = focal / dpy, (cx, cy), zero skew. Exact.
  Eigen::Matrix3d K() const;
};

// Tsai's Euler angles (radians) <-> rotation, as in Willson's code:
//   R = Rz(rz) * Ry(ry) * Rx(rx), each an active rotation about the fixed axis.
Eigen::Matrix3d RotationFromTsaiAngles(double rx, double ry, double rz);
// Inverse of RotationFromTsaiAngles, with ry in [-pi/2, pi/2].
Eigen::Vector3d TsaiAnglesFromRotation(const Eigen::Matrix3d& rotation);

}  // namespace dome::geometry
