#include "geometry/opencv_camera.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/calib3d.hpp>

#include "core/error.h"

namespace dome::geometry {
namespace {

using core::Require;

// The largest distance, in pixels, between OpenCV's projection with every coefficient
// of `d` and with only k1 k2 p1 p2 k3, over a 33 x 33 grid of rays through the image
// (corners included; the rays are those of the undistorted camera, which cover the
// field up to the lens's own distortion).
double DroppedCoefficientsErrorPx(const OpenCvCamera& c, const std::vector<double>& d) {
  std::vector<cv::Point3d> rays;
  const Eigen::Matrix3d k_inv = c.k.inverse();
  for (int gy = 0; gy <= 32; ++gy) {
    for (int gx = 0; gx <= 32; ++gx) {
      const Eigen::Vector3d ray =
          k_inv * Eigen::Vector3d(gx * (c.width_px - 1) / 32.0, gy * (c.height_px - 1) / 32.0, 1);
      rays.emplace_back(ray.x() / ray.z(), ray.y() / ray.z(), 1.0);
    }
  }
  cv::Mat k(3, 3, CV_64F);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) k.at<double>(i, j) = c.k(i, j);
  const cv::Mat zero = cv::Mat::zeros(3, 1, CV_64F);
  std::vector<double> five(d.begin(), d.begin() + std::min<size_t>(d.size(), 5));
  five.resize(5, 0.0);
  std::vector<cv::Point2d> full, kept;
  cv::projectPoints(rays, zero, zero, k, d, full);
  cv::projectPoints(rays, zero, zero, k, five, kept);
  double worst = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    worst = std::max(worst, std::hypot(full[i].x - kept[i].x, full[i].y - kept[i].y));
  }
  return worst;
}

}  // namespace

TsaiCamera CameraFromOpenCv(const OpenCvCamera& c, const std::string& where) {
  Require(c.width_px > 0 && c.height_px > 0, where + ": image size",
          "expected positive width and height, got " + std::to_string(c.width_px) + "x" +
              std::to_string(c.height_px));
  Require(c.k.allFinite(), where + ": K", "must be finite numbers");
  const Eigen::Matrix3d& k = c.k;
  Require(k(1, 0) == 0 && k(2, 0) == 0 && k(2, 1) == 0 && k(2, 2) == 1, where + ": K",
          "expected [fx 0 cx; 0 fy cy; 0 0 1]");
  Require(std::abs(k(0, 1)) <= 1e-9 * std::abs(k(0, 0)), where + ": K",
          "has skew " + std::to_string(k(0, 1)) + "; dome's cameras have none");
  Require(k(0, 0) > 0 && k(1, 1) > 0, where + ": K", "needs positive focal lengths fx, fy");
  const size_t n = c.distortion.size();
  Require(n == 0 || n == 4 || n == 5 || n == 8 || n == 12 || n == 14, where + ": distortion",
          "expected 4, 5, 8, 12 or 14 coefficients (OpenCV's D), got " + std::to_string(n));
  for (double v : c.distortion) {
    Require(std::isfinite(v), where + ": distortion", "coefficients must be finite");
  }
  bool extra = false;
  for (size_t i = 5; i < n; ++i) extra = extra || c.distortion[i] != 0;
  if (extra) {
    char error[64];
    std::snprintf(error, sizeof error, "%.3g", DroppedCoefficientsErrorPx(c, c.distortion));
    throw core::InputError(where + ": distortion",
                           "has coefficients beyond k1 k2 p1 p2 k3 (rational, thin prism or "
                           "tilt), which dome's lens cannot hold: dropping them moves image "
                           "points by up to " +
                               std::string(error) + " px");
  }
  TsaiCamera m;
  m.id = c.id;
  m.width_px = c.width_px;
  m.height_px = c.height_px;
  m.sensor.ncx = m.sensor.nfx = c.width_px;
  m.sensor.dx_mm = m.sensor.dy_mm = 0.01;
  m.focal_mm = k(1, 1) * 0.01;
  m.sx = k(0, 0) / k(1, 1);
  m.cx_px = k(0, 2);
  m.cy_px = k(1, 2);
  const auto d = [&](size_t i) { return i < n ? c.distortion[i] : 0.0; };
  m.lens = {d(0), d(1), d(2), d(3), d(4)};
  m.rotation = c.r;
  m.translation_mm = c.t_mm;
  m.Check(where);  // R a rotation, R and T finite
  return m;
}

}  // namespace dome::geometry
