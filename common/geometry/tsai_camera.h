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
//
// Distortion direction. The model maps distorted -> undistorted in closed form. The
// other way needs the root of  kappa1 * Rd^3 + Rd - Ru = 0  (Rd, Ru radii on the sensor
// plane). Willson's code takes it with Cardano's formula; we use the equivalent
// trigonometric / hyperbolic form of the same closed-form root (DistortedRadiusMm),
// which does not lose digits to cancellation when kappa1 is small:
//   kappa1 > 0: one real root   Rd = 2m sinh(asinh(a) / 3),  m = 1/sqrt(3 k),
//                                a = 1.5 Ru sqrt(3 k)
//   kappa1 < 0: Rd = 2m sin(asin(a) / 3),  m = 1/sqrt(-3 k), a = 1.5 Ru sqrt(-3 k) — the
//               smaller positive of the three real roots, the one continuous with
//               Rd = Ru at the centre (Willson picks the same one). The distorted ->
//               undistorted map only increases up to Rd = m, where Ru reaches
//               Ru_max = 2m/3; an undistorted radius beyond Ru_max has no preimage and
//               is clamped to Rd = m, as in Willson's code (the *IfInRange variants
//               report it instead).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <string>

namespace dome::geometry {

// Known constants of the sensor and frame grabber (Tsai's camera "Geometry").
struct TsaiSensor {
  double ncx = 1.0;     // sensor elements in x (count)
  double nfx = 1.0;     // pixels in a frame-grabber line (count)
  double dx_mm = 0.01;  // centre-to-centre distance of sensor elements in x, in mm
  double dy_mm = 0.01;  // centre-to-centre distance of sensor lines in y, in mm
  // Effective pixel pitch in x of the digitized image, in mm: dx * ncx / nfx.
  double dpx_mm() const { return dx_mm * ncx / nfx; }
  // Effective pixel pitch in y, in mm (Tsai: dpy = dy).
  double dpy_mm() const { return dy_mm; }
};

// Distorted sensor radius Rd (mm) whose undistorted radius is `undistorted_mm`
// (Ru = Rd (1 + kappa1 Rd^2)), in closed form; see the header comment. Returns false
// when kappa1 < 0 and Ru > Ru_max (then *distorted_mm = the clamped radius m).
// Inline: it is on the hot path of every projection.
inline bool DistortedRadiusMm(double undistorted_mm, double kappa1_per_mm2, double* distorted_mm) {
  if (kappa1_per_mm2 == 0.0 || undistorted_mm == 0.0) {
    *distorted_mm = undistorted_mm;
    return true;
  }
  if (kappa1_per_mm2 > 0.0) {
    const double s = std::sqrt(3.0 * kappa1_per_mm2);
    *distorted_mm = (2.0 / s) * std::sinh(std::asinh(1.5 * undistorted_mm * s) / 3.0);
    return true;
  }
  const double s = std::sqrt(-3.0 * kappa1_per_mm2);
  const double a = 1.5 * undistorted_mm * s;
  if (a > 1.0) {
    *distorted_mm = 1.0 / s;  // the largest radius the model reaches; Willson clamps too
    return false;
  }
  *distorted_mm = (2.0 / s) * std::sin(std::asin(a) / 3.0);
  return true;
}

// OpenCV's radial-tangential lens (the model of cv::projectPoints with five
// coefficients), on normalized coordinates of the ideal camera (x, y) = (Xc/Zc, Yc/Zc):
//   r^2 = x^2 + y^2,  radial = 1 + k1 r^2 + k2 r^4 + k3 r^6
//   x_d = x radial + 2 p1 x y + p2 (r^2 + 2 x^2)
//   y_d = y radial + p1 (r^2 + 2 y^2) + 2 p2 x y
// then pixel = (fx x_d + cx, fy y_d + cy) with the camera's K(). It maps undistorted ->
// distorted (Tsai's kappa1 goes the other way); the inverse is found by Newton's method
// to 1e-12 of a normalized unit (OpenCvLens::Undistort).
struct OpenCvLens {
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;
  bool Any() const { return k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0 || k3 != 0; }
  Eigen::Vector2d Distort(const Eigen::Vector2d& n) const {
    const double x = n.x(), y = n.y(), r2 = x * x + y * y;
    const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
    return {x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
            y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y};
  }
  // The undistorted normalized point whose Distort is `d`; false when Newton's method
  // does not converge (beyond the radius where the lens folds back).
  bool Undistort(const Eigen::Vector2d& d, Eigen::Vector2d* n) const;
  // False where the map is not one-to-one any more: the radial factor's derivative
  // d(r radial)/dr <= 0 (strong barrel distortion folding back beyond some radius).
  bool InRange(const Eigen::Vector2d& n) const {
    const double r2 = n.squaredNorm();
    return 1 + r2 * (3 * k1 + r2 * (5 * k2 + r2 * 7 * k3)) > 0;
  }
};

struct TsaiCamera {
  std::string id;     // camera identifier, unique within a rig
  int width_px = 0;   // image width, in pixels
  int height_px = 0;  // image height, in pixels
  TsaiSensor sensor;
  double focal_mm = 0.0;        // effective focal length, in mm
  double kappa1_per_mm2 = 0.0;  // radial distortion, in 1/mm^2
  double cx_px = 0.0;           // image centre x, in pixels
  double cy_px = 0.0;           // image centre y, in pixels
  double sx = 1.0;              // horizontal scale factor
  // OpenCV's lens instead of kappa1 (at most one of the two is set; Check refuses both).
  OpenCvLens lens;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();    // world -> camera
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();  // world -> camera, in mm

  // Throws core::InputError naming `where` and the offending field (e.g.
  // "rig.json: camera c3: focal_mm") when a value is not finite, a size, pitch, sensor
  // count, focal length or sx is not positive, or the rotation is not a proper rotation
  // (orthonormal to 1e-6 per entry of R R^T - I, determinant +1 to 1e-6).
  void Check(const std::string& where) const;

  // Camera centre in world coordinates, in mm: -R^T t.
  Eigen::Vector3d CentreWorld() const;
  // World point (mm) -> camera frame (mm).
  Eigen::Vector3d WorldToCamera(const Eigen::Vector3d& world_mm) const {
    return rotation * world_mm + translation_mm;
  }

  // Any lens distortion (kappa1 or the OpenCV lens).
  bool HasDistortion() const { return kappa1_per_mm2 != 0.0 || lens.Any(); }
  // The exact bytes of every number that maps the ideal image to the recorded one (size,
  // sensor, focal length, kappa1, the OpenCV lens, centre, sx), for keys of what is
  // computed from a camera and kept: equal keys, equal cameras but for the id and pose.
  // A field added to the camera's model must be added here.
  std::string IntrinsicsKey() const;
  // IntrinsicsKey and the pose (rotation, translation): equal keys, equal cameras but
  // for the id.
  std::string Key() const;
  // The same camera without lens distortion (neither kappa1 nor the OpenCV lens): the
  // camera of an undistorted (ideal) image, as geometry/undistort.h makes them.
  TsaiCamera Ideal() const {
    TsaiCamera c = *this;
    c.kappa1_per_mm2 = 0.0;
    c.lens = {};
    return c;
  }

  // World point -> distorted pixel (what the real camera sees). Returns false, and
  // leaves *pixel untouched, when the point is not in front of the camera (Zc <= 0).
  // Beyond Ru_max (kappa1 < 0 only) the radius is clamped as in Willson's code.
  // Allocation-free and inline.
  bool Project(const Eigen::Vector3d& world_mm, Eigen::Vector2d* pixel) const {
    return ProjectCamera(WorldToCamera(world_mm), pixel);
  }
  // Camera-frame point -> distorted pixel; false when Zc <= 0 (or not a number).
  bool ProjectCamera(const Eigen::Vector3d& camera_mm, Eigen::Vector2d* pixel) const;

  // Distorted pixel -> unit ray direction in world coordinates; the ray starts at
  // CentreWorld(). Exact (uses the closed-form distorted->undistorted direction).
  Eigen::Vector3d BackProject(const Eigen::Vector2d& pixel) const;
  // Distorted pixel -> the world point on its ray at camera depth Zc = depth_mm.
  Eigen::Vector3d BackProjectAtDepth(const Eigen::Vector2d& pixel, double depth_mm) const;

  // Pixel of the ideal (kappa1 = 0) camera with the same f, sx, centre and sensor.
  // UndistortPixel is exact (closed form); DistortPixel inverts the cubic exactly
  // (closed-form root, see the header comment) and round-trips to machine precision.
  Eigen::Vector2d UndistortPixel(const Eigen::Vector2d& distorted) const;
  Eigen::Vector2d DistortPixel(const Eigen::Vector2d& undistorted) const;
  // DistortPixel that returns false (leaving *distorted untouched) where DistortPixel
  // would clamp: kappa1 < 0 and the undistorted point beyond Ru_max.
  bool DistortPixelIfInRange(const Eigen::Vector2d& undistorted, Eigen::Vector2d* distorted) const;

  // Sensor-plane helpers (mm).
  Eigen::Vector2d PixelToSensor(const Eigen::Vector2d& pixel) const;
  Eigen::Vector2d SensorToPixel(const Eigen::Vector2d& sensor_mm) const;
  // Ideal pinhole intrinsics of the undistorted camera (see pinhole.h):
  //   fx = focal * sx / dpx, fy = focal / dpy, (cx, cy), zero skew. Exact.
  Eigen::Matrix3d K() const;
};

inline bool TsaiCamera::ProjectCamera(const Eigen::Vector3d& camera_mm,
                                      Eigen::Vector2d* pixel) const {
  if (!(camera_mm.z() > 0.0)) {
    return false;
  }
  if (lens.Any()) {
    const Eigen::Vector2d d =
        lens.Distort(Eigen::Vector2d(camera_mm.x() / camera_mm.z(), camera_mm.y() / camera_mm.z()));
    (*pixel)[0] = focal_mm * sx / sensor.dpx_mm() * d.x() + cx_px;
    (*pixel)[1] = focal_mm / sensor.dpy_mm() * d.y() + cy_px;
    return true;
  }
  // Same order of operations as Willson's world_coord_to_image_coord.
  const double xu = focal_mm * camera_mm.x() / camera_mm.z();
  const double yu = focal_mm * camera_mm.y() / camera_mm.z();
  double lambda = 1.0;
  if (kappa1_per_mm2 != 0.0) {
    const double ru = std::sqrt(xu * xu + yu * yu);
    if (ru > 0.0) {
      double rd;
      DistortedRadiusMm(ru, kappa1_per_mm2, &rd);
      lambda = rd / ru;
    }
  }
  (*pixel)[0] = xu * lambda * sx / sensor.dpx_mm() + cx_px;
  (*pixel)[1] = yu * lambda / sensor.dpy_mm() + cy_px;
  return true;
}

// Tsai's Euler angles (radians) <-> rotation, as in Willson's code:
//   R = Rz(rz) * Ry(ry) * Rx(rx), each an active rotation about the fixed axis.
Eigen::Matrix3d RotationFromTsaiAngles(double rx, double ry, double rz);
// Inverse of RotationFromTsaiAngles, with ry in [-pi/2, pi/2] and rx, rz in (-pi, pi].
// At ry = +-pi/2 (gimbal lock) only one combination of rx and rz is determined; the
// returned angles have rx = 0 and still reproduce the rotation.
Eigen::Vector3d TsaiAnglesFromRotation(const Eigen::Matrix3d& rotation);

}  // namespace dome::geometry
