// Tsai camera <-> pinhole camera K [R | t] with OpenCV's radial distortion.
//
// The pinhole camera (the model of OpenCV, COLMAP, Middlebury, HALCON without
// distortion):
//   camera = R * world + t                       (world -> camera, millimetres)
//   x_u = Xc / Zc, y_u = Yc / Zc                 (normalized, undistorted)
//   x_d = x_u (1 + k1 r^2 + k2 r^4), same for y, r^2 = x_u^2 + y_u^2
//                                                (OpenCV / COLMAP: *forward* distortion
//                                                 of normalized undistorted coordinates)
//   pixel = (fx x_d + cx, fy y_d + cy)           K = [fx 0 cx; 0 fy cy; 0 0 1]
// Pixels follow dome's convention: (0, 0) is the centre of the top-left pixel. (OpenCV
// uses the same; COLMAP does not — see colmap.h.)
//
// What is exact and what is approximate
//  * K, R, t: exact both ways (up to rounding, ~1e-16 relative). Tsai -> pinhole:
//      fx = focal_mm * sx / dpx_mm, fy = focal_mm / dpy_mm, (cx, cy) = (cx_px, cy_px).
//  * Distortion with kappa1 = 0 and k1 = k2 = 0: exact (no distortion either side).
//  * Distortion otherwise: approximate. Tsai *un*distorts distorted sensor coordinates
//    (Xu = Xd (1 + kappa1 Rd^2)) while OpenCV distorts undistorted normalized ones, so no
//    value of one model reproduces the other. For small distortion, to first order,
//    k1 ~= -kappa1 * f^2 (f in mm, square pixels); we instead fit by linear least squares
//    over a grid of pixels covering the whole image (see PinholeConversionOptions) and
//    report in RadialFitReport the residual in pixels of the distorted image: for each
//    grid pixel, how far the converted model puts the pixel of the same ray.
//      Tsai -> pinhole: fits k1 (and k2 when asked), minimizing exactly the reported
//        distorted-pixel residual (it is linear in k1, k2).
//      pinhole -> Tsai: fits kappa1, minimizing the undistorted-pixel residual (linear in
//        kappa1); the report still measures distorted pixels.
//
// Sensor constants chosen for pinhole -> Tsai (a pinhole camera has no sensor; Tsai's
// model needs one, but only dpx / sx and dpy matter for the pixel mapping):
//   ncx = nfx = width_px (one sensor element per pixel, so dpx = dx),
//   dx_mm = dy_mm = options.pixel_pitch_mm (default 0.01 mm, a typical 10 um cell),
//   focal_mm = fy * dy_mm, sx = fx / fy.
// kappa1 (1/mm^2) therefore scales with 1 / pixel_pitch_mm^2; the pixel mapping does
// not depend on the pitch chosen.
#pragma once

#include <Eigen/Core>
#include <string>

#include "geometry/tsai_camera.h"

namespace dome::geometry {

struct PinholeCamera {
  std::string id;     // camera identifier
  int width_px = 0;   // image width, in pixels
  int height_px = 0;  // image height, in pixels
  // Intrinsics, in pixels: [fx s cx; 0 fy cy; 0 0 1]. The skew s must be zero (within
  // 1e-9 fx): the Tsai model has no skew.
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  double k1 = 0.0;  // OpenCV radial coefficient of r^2 (normalized coordinates)
  double k2 = 0.0;  // OpenCV radial coefficient of r^4 (normalized coordinates)
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();    // world -> camera
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();  // world -> camera, in mm

  // Throws core::InputError naming `where` and the field ("K(0,1) (skew)", "k1", ...)
  // when a value is not finite, a size or fx / fy is not positive, K is not of the
  // form above or the rotation is not a rotation (1e-6, as TsaiCamera::Check).
  void Check(const std::string& where) const;
};

struct PinholeConversionOptions {
  // Pinhole -> Tsai: sensor cell size dx = dy, in mm (see the header comment).
  double pixel_pitch_mm = 0.01;
  // Both directions: the fit samples an N x N grid of distorted pixels spanning the
  // whole image, corners included (N = this value, at least 2).
  int fit_samples_per_side = 64;
  // Tsai -> pinhole: also fit k2 (OpenCV's / COLMAP RADIAL's r^4 term); else k2 = 0.
  bool fit_k2 = false;

  // InputError naming the option when one is out of range.
  void Check() const;
};

// How well a converted distortion model reproduces the original over the image.
struct RadialFitReport {
  bool exact = true;             // no distortion on either side: nothing was fitted
  double max_residual_px = 0.0;  // largest distorted-pixel error over the grid, in pixels
  double rms_residual_px = 0.0;  // root mean square of the same, in pixels
  int num_samples = 0;           // grid pixels used
  // Grid pixels left out because the source model maps no ray there (a strongly
  // negative k1 / kappa1 folds the image back on itself before the corner).
  int num_skipped = 0;

  // One line: "exact" or "fitted over N px: max 0.012 px, rms 0.004 px".
  std::string BriefReport() const;
};

// Exact K, R, t; k1 (and k2 with options.fit_k2) fitted to kappa1 when kappa1 != 0.
// `camera` must pass Check (InputError naming camera.id otherwise).
PinholeCamera PinholeFromTsai(const TsaiCamera& camera,
                              const PinholeConversionOptions& options = {},
                              RadialFitReport* report = nullptr);

// Exact K, R, t with the sensor constants above; kappa1 fitted to (k1, k2) when either
// is non-zero. `camera` must pass Check (InputError naming camera.id otherwise).
TsaiCamera TsaiFromPinhole(const PinholeCamera& camera,
                           const PinholeConversionOptions& options = {},
                           RadialFitReport* report = nullptr);

// OpenCV's radial model on normalized coordinates, radius only:
// distorted radius rd = ru (1 + k1 ru^2 + k2 ru^4).
inline double OpenCvDistortRadius(double ru, double k1, double k2) {
  const double s = ru * ru;
  return ru * (1.0 + s * (k1 + s * k2));
}
// Its inverse: the undistorted radius ru on the branch through 0 (where the map
// increases). Closed form when k2 = 0, safeguarded Newton otherwise (to ~1e-15
// relative). Returns false when rd lies beyond the largest radius that branch reaches.
bool OpenCvUndistortRadius(double rd, double k1, double k2, double* ru);

}  // namespace dome::geometry
