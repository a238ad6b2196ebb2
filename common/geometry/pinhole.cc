#include "geometry/pinhole.h"

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "core/error.h"
#include "geometry/parse_util.h"

namespace dome::geometry {
namespace {

using internal::FormatDouble;

std::string Field(const std::string& where, const std::string& field) {
  return where.empty() ? field : where + ": " + field;
}

std::string CameraWhere(const std::string& id) { return "camera '" + id + "'"; }

// The fit grid: N x N pixels from (0, 0) to (width - 1, height - 1), corners included.
std::vector<Eigen::Vector2d> GridPixels(int width_px, int height_px, int per_side) {
  std::vector<Eigen::Vector2d> pixels;
  pixels.reserve(static_cast<size_t>(per_side) * per_side);
  for (int j = 0; j < per_side; ++j) {
    for (int i = 0; i < per_side; ++i) {
      pixels.emplace_back((width_px - 1.0) * i / (per_side - 1.0),
                          (height_px - 1.0) * j / (per_side - 1.0));
    }
  }
  return pixels;
}

void FinishReport(const std::vector<double>& errors_px, int skipped, RadialFitReport* report) {
  if (report == nullptr) {
    return;
  }
  report->exact = false;
  report->num_samples = static_cast<int>(errors_px.size());
  report->num_skipped = skipped;
  double max_error = 0.0;
  double sum_sq = 0.0;
  for (const double e : errors_px) {
    max_error = std::max(max_error, e);
    sum_sq += e * e;
  }
  report->max_residual_px = max_error;
  report->rms_residual_px = errors_px.empty() ? 0.0 : std::sqrt(sum_sq / errors_px.size());
}

}  // namespace

void PinholeCamera::Check(const std::string& where) const {
  core::Require(width_px > 0, Field(where, "width_px"),
                "must be positive, got " + std::to_string(width_px));
  core::Require(height_px > 0, Field(where, "height_px"),
                "must be positive, got " + std::to_string(height_px));
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const std::string index = "(" + std::to_string(i) + "," + std::to_string(j) + ")";
      core::Require(std::isfinite(K(i, j)), Field(where, "K" + index),
                    "must be finite, got " + FormatDouble(K(i, j)));
      core::Require(std::isfinite(rotation(i, j)), Field(where, "rotation" + index),
                    "must be finite, got " + FormatDouble(rotation(i, j)));
    }
    core::Require(std::isfinite(translation_mm[i]),
                  Field(where, "translation_mm[" + std::to_string(i) + "]"),
                  "must be finite, got " + FormatDouble(translation_mm[i]));
  }
  core::Require(K(0, 0) > 0.0, Field(where, "K(0,0) (fx)"),
                "must be positive, got " + FormatDouble(K(0, 0)));
  core::Require(K(1, 1) > 0.0, Field(where, "K(1,1) (fy)"),
                "must be positive, got " + FormatDouble(K(1, 1)));
  core::Require(std::abs(K(0, 1)) <= 1e-9 * K(0, 0), Field(where, "K(0,1) (skew)"),
                "must be zero (the Tsai model has no skew), got " + FormatDouble(K(0, 1)));
  core::Require(K(1, 0) == 0.0 && K(2, 0) == 0.0 && K(2, 1) == 0.0, Field(where, "K"),
                "must be upper triangular [fx 0 cx; 0 fy cy; 0 0 1]");
  core::Require(std::abs(K(2, 2) - 1.0) <= 1e-12, Field(where, "K(2,2)"),
                "must be 1, got " + FormatDouble(K(2, 2)));
  core::Require(std::isfinite(k1), Field(where, "k1"), "must be finite, got " + FormatDouble(k1));
  core::Require(std::isfinite(k2), Field(where, "k2"), "must be finite, got " + FormatDouble(k2));
  internal::RequireRotation(rotation, 1e-6, Field(where, "rotation"));
}

void PinholeConversionOptions::Check() const {
  core::Require(std::isfinite(pixel_pitch_mm) && pixel_pitch_mm > 0.0,
                "PinholeConversionOptions.pixel_pitch_mm",
                "must be positive and finite, got " + FormatDouble(pixel_pitch_mm));
  core::Require(fit_samples_per_side >= 2 && fit_samples_per_side <= 4096,
                "PinholeConversionOptions.fit_samples_per_side",
                "must be in [2, 4096], got " + std::to_string(fit_samples_per_side));
}

std::string RadialFitReport::BriefReport() const {
  if (exact) {
    return "exact (no distortion)";
  }
  char buffer[160];
  std::snprintf(buffer, sizeof(buffer), "fitted over %d px (%d skipped): max %.4g px, rms %.4g px",
                num_samples, num_skipped, max_residual_px, rms_residual_px);
  return buffer;
}

bool OpenCvUndistortRadius(double rd, double k1, double k2, double* ru) {
  if (rd == 0.0 || (k1 == 0.0 && k2 == 0.0)) {
    *ru = rd;
    return true;
  }
  // rd = ru + k1 ru^3 is Tsai's cubic with kappa1 = k1: reuse its closed form.
  if (k2 == 0.0) {
    return DistortedRadiusMm(rd, k1, ru);
  }
  // The branch through 0 ends where d rd / d ru = 1 + 3 k1 s + 5 k2 s^2 (s = ru^2) first
  // reaches zero for s > 0.
  double s_end = std::numeric_limits<double>::infinity();
  const double disc = 9.0 * k1 * k1 - 20.0 * k2;
  if (disc >= 0.0) {
    const double q = std::sqrt(disc);
    for (const double s : {(-3.0 * k1 - q) / (10.0 * k2), (-3.0 * k1 + q) / (10.0 * k2)}) {
      if (s > 0.0) {
        s_end = std::min(s_end, s);
      }
    }
  }
  double lo = 0.0;
  double hi;
  if (std::isfinite(s_end)) {
    hi = std::sqrt(s_end);
    if (OpenCvDistortRadius(hi, k1, k2) < rd) {
      return false;
    }
  } else {
    // Increasing everywhere and unbounded: grow a bracket.
    hi = rd;
    for (int i = 0; i < 200 && OpenCvDistortRadius(hi, k1, k2) < rd; ++i) {
      hi *= 2.0;
    }
  }
  // Newton from the rd guess, falling back to bisection whenever a step leaves [lo, hi].
  double r = std::min(rd, hi);
  for (int iteration = 0; iteration < 200; ++iteration) {
    const double f = OpenCvDistortRadius(r, k1, k2) - rd;
    if (f == 0.0) {
      break;
    }
    if (f < 0.0) {
      lo = r;
    } else {
      hi = r;
    }
    const double s = r * r;
    const double slope = 1.0 + s * (3.0 * k1 + 5.0 * k2 * s);
    double next = slope > 0.0 ? r - f / slope : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) {
      next = 0.5 * (lo + hi);
    }
    if (std::abs(next - r) <= 1e-16 * r) {
      r = next;
      break;
    }
    r = next;
  }
  *ru = r;
  return true;
}

PinholeCamera PinholeFromTsai(const TsaiCamera& camera, const PinholeConversionOptions& options,
                              RadialFitReport* report) {
  camera.Check(CameraWhere(camera.id));
  options.Check();
  core::Require(!camera.lens.Any(), CameraWhere(camera.id) + ": lens",
                "an OpenCV lens with tangential terms has no k1/k2 pinhole equivalent here; "
                "undistort the images and convert the ideal camera");
  PinholeCamera pinhole;
  pinhole.id = camera.id;
  pinhole.width_px = camera.width_px;
  pinhole.height_px = camera.height_px;
  pinhole.K = camera.K();
  pinhole.rotation = camera.rotation;
  pinhole.translation_mm = camera.translation_mm;
  if (report != nullptr) {
    *report = RadialFitReport{};
  }
  if (camera.kappa1_per_mm2 == 0.0) {
    return pinhole;
  }

  // For every grid pixel p_d of the distorted image: its exact undistorted pixel p_u,
  // normalized x_u. OpenCV predicts p_d' = p_u + k1 r^2 f.*x_u + k2 r^4 f.*x_u: linear.
  const double fx = pinhole.K(0, 0), fy = pinhole.K(1, 1);
  const double cx = pinhole.K(0, 2), cy = pinhole.K(1, 2);
  const std::vector<Eigen::Vector2d> grid =
      GridPixels(camera.width_px, camera.height_px, options.fit_samples_per_side);
  const int unknowns = options.fit_k2 ? 2 : 1;
  Eigen::MatrixXd a(2 * grid.size(), unknowns);
  Eigen::VectorXd b(2 * grid.size());
  for (size_t i = 0; i < grid.size(); ++i) {
    const Eigen::Vector2d& pd = grid[i];
    const Eigen::Vector2d pu = camera.UndistortPixel(pd);
    const double xu = (pu.x() - cx) / fx, yu = (pu.y() - cy) / fy;
    const double r2 = xu * xu + yu * yu;
    a(2 * i, 0) = fx * xu * r2;
    a(2 * i + 1, 0) = fy * yu * r2;
    if (options.fit_k2) {
      a(2 * i, 1) = fx * xu * r2 * r2;
      a(2 * i + 1, 1) = fy * yu * r2 * r2;
    }
    b(2 * i) = pd.x() - pu.x();
    b(2 * i + 1) = pd.y() - pu.y();
  }
  const Eigen::VectorXd k = a.colPivHouseholderQr().solve(b);
  pinhole.k1 = k(0);
  pinhole.k2 = options.fit_k2 ? k(1) : 0.0;

  std::vector<double> errors_px(grid.size());
  const Eigen::VectorXd residual = a * k - b;
  for (size_t i = 0; i < grid.size(); ++i) {
    errors_px[i] = std::hypot(residual(2 * i), residual(2 * i + 1));
  }
  FinishReport(errors_px, 0, report);
  return pinhole;
}

TsaiCamera TsaiFromPinhole(const PinholeCamera& camera, const PinholeConversionOptions& options,
                           RadialFitReport* report) {
  camera.Check(CameraWhere(camera.id));
  options.Check();
  TsaiCamera tsai;
  tsai.id = camera.id;
  tsai.width_px = camera.width_px;
  tsai.height_px = camera.height_px;
  tsai.sensor.ncx = camera.width_px;
  tsai.sensor.nfx = camera.width_px;
  tsai.sensor.dx_mm = options.pixel_pitch_mm;
  tsai.sensor.dy_mm = options.pixel_pitch_mm;
  const double fx = camera.K(0, 0), fy = camera.K(1, 1);
  const double cx = camera.K(0, 2), cy = camera.K(1, 2);
  tsai.focal_mm = fy * options.pixel_pitch_mm;
  tsai.sx = fx / fy;
  tsai.cx_px = cx;
  tsai.cy_px = cy;
  tsai.rotation = camera.rotation;
  tsai.translation_mm = camera.translation_mm;
  if (report != nullptr) {
    *report = RadialFitReport{};
  }
  if (camera.k1 == 0.0 && camera.k2 == 0.0) {
    return tsai;
  }

  // For every grid pixel p_d that OpenCV's model reaches: its undistorted pixel p_u.
  // Tsai predicts p_u' = p_d + kappa1 Rd^2 (p_d - c): linear in kappa1.
  const std::vector<Eigen::Vector2d> grid =
      GridPixels(camera.width_px, camera.height_px, options.fit_samples_per_side);
  std::vector<Eigen::Vector2d> distorted, undistorted;
  distorted.reserve(grid.size());
  undistorted.reserve(grid.size());
  int skipped = 0;
  double num = 0.0, den = 0.0;
  for (const Eigen::Vector2d& pd : grid) {
    const double xd = (pd.x() - cx) / fx, yd = (pd.y() - cy) / fy;
    const double rd = std::hypot(xd, yd);
    double ru;
    if (!OpenCvUndistortRadius(rd, camera.k1, camera.k2, &ru)) {
      ++skipped;
      continue;
    }
    const double scale = rd > 0.0 ? ru / rd : 1.0;
    const Eigen::Vector2d pu(cx + fx * xd * scale, cy + fy * yd * scale);
    const double rd2_mm = tsai.PixelToSensor(pd).squaredNorm();
    const Eigen::Vector2d column = rd2_mm * (pd - Eigen::Vector2d(cx, cy));
    const Eigen::Vector2d target = pu - pd;
    num += column.dot(target);
    den += column.squaredNorm();
    distorted.push_back(pd);
    undistorted.push_back(pu);
  }
  core::Require(den > 0.0, CameraWhere(camera.id),
                "k1 = " + FormatDouble(camera.k1) + ", k2 = " + FormatDouble(camera.k2) +
                    " map no pixel of the image to a ray; cannot fit Tsai's kappa1");
  tsai.kappa1_per_mm2 = num / den;

  // Report in distorted pixels: where the Tsai model puts the ray of p_u versus p_d.
  std::vector<double> errors_px(distorted.size());
  for (size_t i = 0; i < distorted.size(); ++i) {
    errors_px[i] = (tsai.DistortPixel(undistorted[i]) - distorted[i]).norm();
  }
  FinishReport(errors_px, skipped, report);
  return tsai;
}

}  // namespace dome::geometry
