#include "geometry/tsai_camera.h"

#include <Eigen/LU>
#include <cmath>

#include "core/error.h"
#include "geometry/parse_util.h"

namespace dome::geometry {

std::string TsaiCamera::IntrinsicsKey() const {
  const double numbers[] = {double(width_px), double(height_px), sensor.ncx, sensor.nfx,
                            sensor.dx_mm,     sensor.dy_mm,      focal_mm,   kappa1_per_mm2,
                            lens.k1,          lens.k2,           lens.p1,    lens.p2,
                            lens.k3,          cx_px,             cy_px,      sx};
  return std::string(reinterpret_cast<const char*>(numbers), sizeof numbers);
}

std::string TsaiCamera::Key() const {
  const double pose[] = {rotation(0, 0), rotation(0, 1),    rotation(0, 2),    rotation(1, 0),
                         rotation(1, 1), rotation(1, 2),    rotation(2, 0),    rotation(2, 1),
                         rotation(2, 2), translation_mm(0), translation_mm(1), translation_mm(2)};
  return IntrinsicsKey() + std::string(reinterpret_cast<const char*>(pose), sizeof pose);
}
namespace {

using internal::FormatDouble;

std::string Field(const std::string& where, const std::string& field) {
  return where.empty() ? field : where + ": " + field;
}

void RequireFinite(double value, const std::string& where, const std::string& field) {
  core::Require(std::isfinite(value), Field(where, field),
                "must be finite, got " + FormatDouble(value));
}

void RequirePositive(double value, const std::string& where, const std::string& field) {
  core::Require(std::isfinite(value) && value > 0.0, Field(where, field),
                "must be positive and finite, got " + FormatDouble(value));
}

}  // namespace

void TsaiCamera::Check(const std::string& where) const {
  core::Require(width_px > 0, Field(where, "width_px"),
                "must be positive, got " + std::to_string(width_px));
  core::Require(height_px > 0, Field(where, "height_px"),
                "must be positive, got " + std::to_string(height_px));
  RequirePositive(sensor.ncx, where, "sensor.ncx");
  RequirePositive(sensor.nfx, where, "sensor.nfx");
  RequirePositive(sensor.dx_mm, where, "sensor.dx_mm");
  RequirePositive(sensor.dy_mm, where, "sensor.dy_mm");
  RequirePositive(sensor.dpx_mm(), where, "sensor.dpx_mm (dx * ncx / nfx)");
  RequirePositive(focal_mm, where, "focal_mm");
  RequireFinite(kappa1_per_mm2, where, "kappa1_per_mm2");
  for (const auto& [v, name] :
       {std::pair{lens.k1, "lens.k1"}, std::pair{lens.k2, "lens.k2"}, std::pair{lens.p1, "lens.p1"},
        std::pair{lens.p2, "lens.p2"}, std::pair{lens.k3, "lens.k3"}})
    RequireFinite(v, where, name);
  core::Require(!(lens.Any() && kappa1_per_mm2 != 0.0), Field(where, "lens"),
                "cannot be combined with kappa1_per_mm2 (one distortion model per camera)");
  RequireFinite(cx_px, where, "cx_px");
  RequireFinite(cy_px, where, "cy_px");
  RequirePositive(sx, where, "sx");
  for (int i = 0; i < 3; ++i) {
    RequireFinite(translation_mm[i], where, "translation_mm[" + std::to_string(i) + "]");
    for (int j = 0; j < 3; ++j) {
      RequireFinite(rotation(i, j), where,
                    "rotation(" + std::to_string(i) + "," + std::to_string(j) + ")");
    }
  }
  internal::RequireRotation(rotation, 1e-6, Field(where, "rotation"));
}

Eigen::Vector3d TsaiCamera::CentreWorld() const { return -(rotation.transpose() * translation_mm); }

Eigen::Vector2d TsaiCamera::PixelToSensor(const Eigen::Vector2d& pixel) const {
  return {(pixel.x() - cx_px) * sensor.dpx_mm() / sx, (pixel.y() - cy_px) * sensor.dpy_mm()};
}

Eigen::Vector2d TsaiCamera::SensorToPixel(const Eigen::Vector2d& sensor_mm) const {
  return {sensor_mm.x() * sx / sensor.dpx_mm() + cx_px, sensor_mm.y() / sensor.dpy_mm() + cy_px};
}

bool OpenCvLens::Undistort(const Eigen::Vector2d& d, Eigen::Vector2d* n) const {
  Eigen::Vector2d u = d;
  for (int it = 0; it < 50; ++it) {
    const double x = u.x(), y = u.y(), r2 = x * x + y * y;
    const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double dradial = k1 + r2 * (2 * k2 + r2 * 3 * k3);  // d radial / d(r^2)
    Eigen::Matrix2d j;
    j(0, 0) = radial + x * dradial * 2 * x + 2 * p1 * y + 6 * p2 * x;
    j(0, 1) = x * dradial * 2 * y + 2 * p1 * x + 2 * p2 * y;
    j(1, 0) = y * dradial * 2 * x + 2 * p1 * x + 2 * p2 * y;
    j(1, 1) = radial + y * dradial * 2 * y + 6 * p1 * y + 2 * p2 * x;
    const Eigen::Vector2d f = Distort(u) - d;
    if (f.norm() < 1e-13) {
      *n = u;
      return InRange(u);
    }
    u -= j.inverse() * f;
    if (!u.allFinite()) return false;
  }
  *n = u;
  return (Distort(u) - d).norm() < 1e-10 && InRange(u);
}

namespace {
// Pixel <-> normalized coordinates of the ideal camera.
Eigen::Vector2d Normalized(const TsaiCamera& c, const Eigen::Vector2d& px) {
  return {(px.x() - c.cx_px) * c.sensor.dpx_mm() / (c.focal_mm * c.sx),
          (px.y() - c.cy_px) * c.sensor.dpy_mm() / c.focal_mm};
}
Eigen::Vector2d Pixel(const TsaiCamera& c, const Eigen::Vector2d& n) {
  return {c.focal_mm * c.sx / c.sensor.dpx_mm() * n.x() + c.cx_px,
          c.focal_mm / c.sensor.dpy_mm() * n.y() + c.cy_px};
}
}  // namespace

Eigen::Vector2d TsaiCamera::UndistortPixel(const Eigen::Vector2d& distorted) const {
  if (lens.Any()) {
    Eigen::Vector2d n;
    lens.Undistort(Normalized(*this, distorted), &n);
    return Pixel(*this, n);
  }
  if (kappa1_per_mm2 == 0.0) {
    return distorted;
  }
  const Eigen::Vector2d d = PixelToSensor(distorted);
  return SensorToPixel(d * (1.0 + kappa1_per_mm2 * d.squaredNorm()));
}

bool TsaiCamera::DistortPixelIfInRange(const Eigen::Vector2d& undistorted,
                                       Eigen::Vector2d* distorted) const {
  if (lens.Any()) {
    const Eigen::Vector2d n = Normalized(*this, undistorted);
    if (!lens.InRange(n)) return false;
    *distorted = Pixel(*this, lens.Distort(n));
    return true;
  }
  if (kappa1_per_mm2 == 0.0) {
    *distorted = undistorted;
    return true;
  }
  const Eigen::Vector2d u = PixelToSensor(undistorted);
  const double ru = u.norm();
  if (ru == 0.0) {
    *distorted = undistorted;
    return true;
  }
  double rd;
  if (!DistortedRadiusMm(ru, kappa1_per_mm2, &rd)) {
    return false;
  }
  *distorted = SensorToPixel(u * (rd / ru));
  return true;
}

Eigen::Vector2d TsaiCamera::DistortPixel(const Eigen::Vector2d& undistorted) const {
  if (lens.Any()) return Pixel(*this, lens.Distort(Normalized(*this, undistorted)));
  if (kappa1_per_mm2 == 0.0) {
    return undistorted;
  }
  const Eigen::Vector2d u = PixelToSensor(undistorted);
  const double ru = u.norm();
  if (ru == 0.0) {
    return undistorted;
  }
  double rd;
  DistortedRadiusMm(ru, kappa1_per_mm2, &rd);  // clamps beyond Ru_max, as Willson does
  return SensorToPixel(u * (rd / ru));
}

Eigen::Vector3d TsaiCamera::BackProject(const Eigen::Vector2d& pixel) const {
  if (lens.Any()) {
    Eigen::Vector2d n;
    lens.Undistort(Normalized(*this, pixel), &n);
    return rotation.transpose() * Eigen::Vector3d(n.x(), n.y(), 1.0).normalized();
  }
  const Eigen::Vector2d d = PixelToSensor(pixel);
  const Eigen::Vector2d u = d * (1.0 + kappa1_per_mm2 * d.squaredNorm());
  const Eigen::Vector3d ray_camera(u.x(), u.y(), focal_mm);
  return rotation.transpose() * ray_camera.normalized();
}

Eigen::Vector3d TsaiCamera::BackProjectAtDepth(const Eigen::Vector2d& pixel,
                                               double depth_mm) const {
  if (lens.Any()) {
    Eigen::Vector2d n;
    lens.Undistort(Normalized(*this, pixel), &n);
    return rotation.transpose() *
           (Eigen::Vector3d(n.x() * depth_mm, n.y() * depth_mm, depth_mm) - translation_mm);
  }
  const Eigen::Vector2d d = PixelToSensor(pixel);
  const Eigen::Vector2d u = d * (1.0 + kappa1_per_mm2 * d.squaredNorm());
  const Eigen::Vector3d camera_mm(u.x() * depth_mm / focal_mm, u.y() * depth_mm / focal_mm,
                                  depth_mm);
  return rotation.transpose() * (camera_mm - translation_mm);
}

Eigen::Matrix3d TsaiCamera::K() const {
  Eigen::Matrix3d k = Eigen::Matrix3d::Identity();
  k(0, 0) = focal_mm * sx / sensor.dpx_mm();
  k(1, 1) = focal_mm / sensor.dpy_mm();
  k(0, 2) = cx_px;
  k(1, 2) = cy_px;
  return k;
}

Eigen::Matrix3d RotationFromTsaiAngles(double rx, double ry, double rz) {
  // Willson's matrix (cal_main.c), a = rx, b = ry, g = rz; equal to Rz(g) Ry(b) Rx(a).
  const double sa = std::sin(rx), ca = std::cos(rx);
  const double sb = std::sin(ry), cb = std::cos(ry);
  const double sg = std::sin(rz), cg = std::cos(rz);
  Eigen::Matrix3d r;
  r << cb * cg, cg * sa * sb - ca * sg, sa * sg + ca * cg * sb,  //
      cb * sg, sa * sb * sg + ca * cg, ca * sb * sg - cg * sa,   //
      -sb, cb * sa, ca * cb;
  return r;
}

Eigen::Vector3d TsaiAnglesFromRotation(const Eigen::Matrix3d& r) {
  // r7 = -sin(b), r8 = cos(b) sin(a), r9 = cos(a) cos(b), r1 = cos(b) cos(g),
  // r4 = cos(b) sin(g). atan2 of both components keeps full precision everywhere,
  // unlike asin(-r7) near b = +-pi/2.
  const double cb = std::hypot(r(0, 0), r(1, 0));
  const double ry = std::atan2(-r(2, 0), cb);
  if (cb > 1e-12) {
    return {std::atan2(r(2, 1), r(2, 2)), ry, std::atan2(r(1, 0), r(0, 0))};
  }
  // Gimbal lock, cos(b) = 0: with a = 0, r2 = -sin(g) and r5 = cos(g) for either sign of b.
  return {0.0, ry, std::atan2(-r(0, 1), r(1, 1))};
}

}  // namespace dome::geometry
