#include "calib/point_calibration.h"

#include <fmt/format.h>

#include <Eigen/SVD>
#include <cmath>
#include <sstream>

#include "core/error.h"
#include "geometry/tsai_camera.h"
#include "io/file_util.h"

namespace dome::calib {
namespace {

ErrorStats Stats(const std::vector<double>& v) {
  ErrorStats s;
  if (v.empty()) return s;
  for (double x : v) s.mean += x, s.max = std::max(s.max, x);
  s.mean /= double(v.size());
  for (double x : v) s.stddev += (x - s.mean) * (x - s.mean);
  s.stddev = v.size() > 1 ? std::sqrt(s.stddev / double(v.size() - 1)) : 0.0;
  return s;
}

}  // namespace

std::vector<Correspondence> ReadPointFile(const std::filesystem::path& path) {
  std::istringstream in(io::ReadFileBytes(path));
  std::vector<Correspondence> points;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    for (char& c : line)
      if (c == ',' || c == '\t' || c == ';') c = ' ';
    std::istringstream row(line);
    std::string first;
    if (!(row >> first) || first[0] == '#') continue;
    std::istringstream values(line);
    double v[5];
    int got = 0;
    while (got < 5 && values >> v[got]) ++got;
    if (got == 0 && points.empty() && n == 1) continue;  // a header of column names
    std::string rest;
    core::Require(got == 5 && !(values >> rest), path.string() + ":" + std::to_string(n),
                  "expected 5 numbers x y z Xf Yf, got '" + line + "'");
    for (double x : v)
      core::Require(std::isfinite(x), path.string() + ":" + std::to_string(n), "not finite");
    Correspondence c;
    c.id = int(points.size());
    c.target_mm = Eigen::Vector3d(v[0], v[1], v[2]);
    c.pixel = Eigen::Vector2d(v[3], v[4]);
    points.push_back(c);
  }
  core::Require(!points.empty(), path.string(), "holds no correspondence (x y z Xf Yf)");
  return points;
}

void EvaluatePoints(const geometry::TsaiCamera& camera, const std::vector<Correspondence>& points,
                    PointCalibration* out) {
  const geometry::TsaiCamera ideal = camera.Ideal();
  std::vector<double> dist, undist, object, normalized;
  const double f = camera.focal_mm;
  const double quant = (std::pow(camera.sensor.dpx_mm() / camera.sx / f, 2) +
                        std::pow(camera.sensor.dpy_mm() / f, 2)) /
                       12.0;
  for (const auto& c : points) {
    Eigen::Vector2d px, ideal_px;
    const Eigen::Vector3d pc = camera.WorldToCamera(c.target_mm);
    if (!camera.Project(c.target_mm, &px) || !ideal.Project(c.target_mm, &ideal_px)) {
      dist.push_back(INFINITY);
      continue;
    }
    dist.push_back((px - c.pixel).norm());
    undist.push_back((ideal_px - camera.UndistortPixel(c.pixel)).norm());
    const Eigen::Vector3d ray = camera.BackProject(c.pixel);
    const Eigen::Vector3d v = c.target_mm - camera.CentreWorld();
    object.push_back((v - v.dot(ray) * ray).norm());
    // The observed ray at the point's depth, in the camera frame.
    const Eigen::Vector3d at = camera.WorldToCamera(camera.BackProjectAtDepth(c.pixel, pc.z()));
    normalized.push_back(
        std::sqrt(((at.x() - pc.x()) * (at.x() - pc.x()) + (at.y() - pc.y()) * (at.y() - pc.y())) /
                  (pc.z() * pc.z() * quant)));
  }
  out->distorted_px = Stats(dist);
  out->undistorted_px = Stats(undist);
  out->object_mm = Stats(object);
  out->normalized_error = Stats(normalized).mean;
}

PointCalibration CalibrateFromPoints(const CameraPrior& prior,
                                     const std::vector<Correspondence>& points,
                                     const std::string& where) {
  core::Require(points.size() >= 7, where,
                "needs at least 7 correspondences, got " + std::to_string(points.size()));
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& c : points) mean += c.target_mm;
  mean /= double(points.size());
  Eigen::MatrixXd centred(points.size(), 3);
  bool all_z0 = true;
  for (size_t i = 0; i < points.size(); ++i) {
    centred.row(i) = (points[i].target_mm - mean).transpose();
    all_z0 &= points[i].target_mm.z() == 0.0;
  }
  const Eigen::Vector3d sv = Eigen::JacobiSVD<Eigen::MatrixXd>(centred).singularValues();
  core::Require(sv(1) > 1e-6 * sv(0), where,
                "the points are collinear: a line cannot fix a camera (Tsai needs a plane at "
                "z = 0 or points spanning a volume)");
  PointCalibration out;
  out.coplanar = all_z0;
  TsaiInitOptions init;
  init.min_points_noncoplanar = 7;
  init.min_points_coplanar = 7;
  // Willson's starting image centre: the middle of the frame buffer.
  const double cx = 0.5 * prior.width_px, cy = 0.5 * prior.height_px;
  geometry::TsaiCamera cam;
  RefineOptions refine;
  if (all_z0) {
    // f is estimated; sx stays 1.
    const geometry::TsaiCamera intrinsics = prior.Camera(1.0, cx, cy, 1.0);
    cam = TsaiInitCoplanar(intrinsics, points, /*fix_focal=*/false, init, where);
    refine.refine_sx = false;  // coplanar points do not determine sx (Willson's ccal)
  } else {
    cam = TsaiInitNonCoplanar(prior, cx, cy, points, init, where);
  }
  std::vector<View> views(1);
  views[0].name = where;
  views[0].points = points;
  views[0].rotation = cam.rotation;
  views[0].translation_mm = cam.translation_mm;
  out.refine = RefineCamera(&cam, &views, refine, where);
  cam.rotation = views[0].rotation;
  cam.translation_mm = views[0].translation_mm;
  cam.Check(where + ": result");
  out.camera = cam;
  EvaluatePoints(cam, points, &out);
  return out;
}

std::string PointCalibration::Report() const {
  const auto& c = camera;
  const Eigen::Vector3d a = geometry::TsaiAnglesFromRotation(c.rotation) * 180.0 / M_PI;
  auto line = [](const char* name, const ErrorStats& s, const char* unit) {
    return fmt::format("{:<32} mean {:.6f}  stddev {:.6f}  max {:.6f} {}\n", name, s.mean, s.stddev,
                       s.max, unit);
  };
  std::string r = fmt::format(
      "{} calibration ({} points, {} LM iterations{})\n"
      "f = {:.6f} mm  kappa1 = {:.6e} 1/mm^2  Cx = {:.4f}  Cy = {:.4f} px  sx = {:.6f}\n"
      "Rx = {:.6f}  Ry = {:.6f}  Rz = {:.6f} deg  Tx = {:.4f}  Ty = {:.4f}  Tz = {:.4f} mm\n",
      coplanar ? "coplanar (ccal)" : "non-coplanar (ncal)", refine.residuals / 2, refine.iterations,
      refine.converged ? "" : ", not converged", c.focal_mm, c.kappa1_per_mm2, c.cx_px, c.cy_px,
      c.sx, a.x(), a.y(), a.z(), c.translation_mm.x(), c.translation_mm.y(), c.translation_mm.z());
  r += line("distorted image plane error", distorted_px, "px");
  r += line("undistorted image plane error", undistorted_px, "px");
  r += line("object space error", object_mm, "mm");
  r += fmt::format("normalized calibration error     {:.6f}\n", normalized_error);
  return r;
}

}  // namespace dome::calib
