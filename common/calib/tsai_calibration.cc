#include "calib/tsai_calibration.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <unsupported/Eigen/LevenbergMarquardt>

#include "core/error.h"

namespace dome::calib {

using Eigen::Matrix3d;
using Eigen::MatrixXd;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Eigen::VectorXd;

void TsaiInitOptions::Check() const {
  core::Require(min_volume_ratio > 0 && min_volume_ratio < 1, "TsaiInitOptions: min_volume_ratio",
                "must be in (0, 1)");
  core::Require(min_points_noncoplanar >= 7, "TsaiInitOptions: min_points_noncoplanar",
                "must be at least 7 (Tsai's non-coplanar system has 7 unknowns)");
  core::Require(min_points_coplanar >= 5, "TsaiInitOptions: min_points_coplanar",
                "must be at least 5 (Tsai's coplanar system has 5 unknowns)");
}

void RefineOptions::Check() const {
  core::Require(max_function_evaluations > 0, "RefineOptions: max_function_evaluations",
                "must be positive");
}

namespace {

Matrix3d NearestRotation(const Matrix3d& m) {
  Eigen::JacobiSVD<Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Matrix3d r = svd.matrixU() * svd.matrixV().transpose();
  if (r.determinant() < 0) {
    Matrix3d u = svd.matrixU();
    u.col(2) *= -1;
    r = u * svd.matrixV().transpose();
  }
  return r;
}

void CheckFinite(const std::vector<Correspondence>& points, const std::string& where) {
  for (const auto& c : points) {
    core::Require(c.target_mm.allFinite() && c.pixel.allFinite(), where,
                  fmt::format("point {} has a coordinate that is not a finite number", c.id));
  }
}

// f and tz from Tsai's second linear step, Yd (r3.p + tz) = f (r2.p + ty), together
// with its x counterpart Xd (r3.p + tz) = f (r1.p + tx) (Willson uses y only; both rows
// make it well conditioned when the points span little of one image axis).
bool SolveFocalTz(const Matrix3d& r, double tx, double ty,
                  const std::vector<Correspondence>& points, const std::vector<Vector2d>& sensor,
                  double* f, double* tz) {
  const int n = static_cast<int>(points.size());
  MatrixXd a(2 * n, 2);
  VectorXd b(2 * n);
  for (int i = 0; i < n; ++i) {
    const Vector3d& p = points[i].target_mm;
    const double xc = r.row(0).dot(p) + tx;
    const double yc = r.row(1).dot(p) + ty;
    const double w = r.row(2).dot(p);
    a(2 * i, 0) = yc;
    a(2 * i, 1) = -sensor[i].y();
    b(2 * i) = w * sensor[i].y();
    a(2 * i + 1, 0) = xc;
    a(2 * i + 1, 1) = -sensor[i].x();
    b(2 * i + 1) = w * sensor[i].x();
  }
  const Eigen::Vector2d x = a.colPivHouseholderQr().solve(b);
  if (!x.allFinite()) return false;
  *f = x(0);
  *tz = x(1);
  return true;
}

// Tsai's sign test: a negative focal length means the rotation's third row and column
// have the wrong sign; flip them and solve again (throws naming `where` when singular).
void SolveFocalTzWithSign(Matrix3d* r, double tx, double ty,
                          const std::vector<Correspondence>& points,
                          const std::vector<Vector2d>& sensor, const std::string& where, double* f,
                          double* tz) {
  core::Require(SolveFocalTz(*r, tx, ty, points, sensor, f, tz), where,
                "degenerate solution (f, tz)");
  if (*f >= 0) return;
  (*r)(0, 2) = -(*r)(0, 2);
  (*r)(1, 2) = -(*r)(1, 2);
  (*r)(2, 0) = -(*r)(2, 0);
  (*r)(2, 1) = -(*r)(2, 1);
  *r = NearestRotation(*r);
  core::Require(SolveFocalTz(*r, tx, ty, points, sensor, f, tz), where,
                "degenerate solution (f, tz)");
}

// Resolves the sign of ty with the point farthest from the image centre: the camera
// frame x, y of a point have the signs of its sensor coordinates (Tsai, step 3).
bool TyIsPositive(const Vector3d& r1_over, const Vector3d& r2_over, double tx_over, double ty,
                  const Vector3d& p, const Vector2d& s) {
  const double xc = r1_over.dot(p) * ty + tx_over * ty;
  const double yc = r2_over.dot(p) * ty + ty;
  return (xc >= 0) == (s.x() >= 0) && (yc >= 0) == (s.y() >= 0);
}

void RequireInFront(const geometry::TsaiCamera& cam, const std::vector<Correspondence>& points,
                    const std::string& where) {
  int behind = 0;
  int first = -1;
  for (const auto& c : points) {
    if (!(cam.WorldToCamera(c.target_mm).z() > 0)) {
      ++behind;
      if (first < 0) first = c.id;
    }
  }
  core::Require(
      behind == 0, where,
      fmt::format("{} of {} points (first: id {}) are behind the camera in the closed-form "
                  "solution; the image points do not match the target (mismatched ids or "
                  "a mirrored target?)",
                  behind, points.size(), first));
  core::Require(cam.focal_mm > 0 && std::isfinite(cam.focal_mm), where,
                "the closed-form solution has no positive focal length (degenerate geometry)");
}

}  // namespace

namespace {

// Tsai's linear step divides by ty, the camera-frame y of the target origin: when the
// origin images near the centre row (the synthetic object's corner does), the system is
// ill conditioned. The closed forms therefore run in a target frame shifted to the
// point imaged farthest from the centre row, and the translation is shifted back.
Vector3d ConditioningOrigin(const std::vector<Correspondence>& points, double cy_px) {
  size_t best = 0;
  for (size_t i = 1; i < points.size(); ++i) {
    if (std::abs(points[i].pixel.y() - cy_px) > std::abs(points[best].pixel.y() - cy_px)) best = i;
  }
  return points.empty() ? Vector3d::Zero() : points[best].target_mm;
}

std::vector<Correspondence> Shifted(std::vector<Correspondence> points, const Vector3d& origin) {
  for (auto& c : points) c.target_mm -= origin;
  return points;
}

geometry::TsaiCamera NonCoplanarImpl(const CameraPrior& prior, double cx_px, double cy_px,
                                     const std::vector<Correspondence>& points,
                                     const TsaiInitOptions& options, const std::string& where);
geometry::TsaiCamera CoplanarImpl(const geometry::TsaiCamera& intrinsics,
                                  const std::vector<Correspondence>& points, bool fix_focal,
                                  const TsaiInitOptions& options, const std::string& where);

}  // namespace

geometry::TsaiCamera TsaiInitNonCoplanar(const CameraPrior& prior, double cx_px, double cy_px,
                                         const std::vector<Correspondence>& points,
                                         const TsaiInitOptions& options, const std::string& where) {
  options.Check();
  const int n = static_cast<int>(points.size());
  core::Require(n >= options.min_points_noncoplanar, where,
                fmt::format("{} calibration points; the non-coplanar calibration needs at least {}",
                            n, options.min_points_noncoplanar));
  CheckFinite(points, where);
  const Vector3d origin = ConditioningOrigin(points, cy_px);
  geometry::TsaiCamera cam =
      NonCoplanarImpl(prior, cx_px, cy_px, Shifted(points, origin), options, where);
  cam.translation_mm -= cam.rotation * origin;
  RequireInFront(cam, points, where);
  return cam;
}

geometry::TsaiCamera TsaiInitCoplanar(const geometry::TsaiCamera& intrinsics,
                                      const std::vector<Correspondence>& points, bool fix_focal,
                                      const TsaiInitOptions& options, const std::string& where) {
  options.Check();
  const int n = static_cast<int>(points.size());
  core::Require(n >= options.min_points_coplanar, where,
                fmt::format("{} calibration points; the coplanar calibration needs at least {}", n,
                            options.min_points_coplanar));
  CheckFinite(points, where);
  Vector3d origin = ConditioningOrigin(points, intrinsics.cy_px);
  origin.z() = 0.0;  // stay on the plane
  geometry::TsaiCamera cam =
      CoplanarImpl(intrinsics, Shifted(points, origin), fix_focal, options, where);
  cam.translation_mm -= cam.rotation * origin;
  RequireInFront(cam, points, where);
  return cam;
}

namespace {

geometry::TsaiCamera NonCoplanarImpl(const CameraPrior& prior, double cx_px, double cy_px,
                                     const std::vector<Correspondence>& points,
                                     const TsaiInitOptions& options, const std::string& where) {
  const int n = static_cast<int>(points.size());
  core::Require(n >= options.min_points_noncoplanar, where,
                fmt::format("{} calibration points; the non-coplanar calibration needs at least {}",
                            n, options.min_points_noncoplanar));
  CheckFinite(points, where);
  // The points must span a volume, or the 7-unknown system is rank deficient.
  Vector3d mean = Vector3d::Zero();
  for (const auto& c : points) mean += c.target_mm;
  mean /= n;
  Matrix3d scatter = Matrix3d::Zero();
  for (const auto& c : points) scatter += (c.target_mm - mean) * (c.target_mm - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Matrix3d> eig(scatter);
  const Vector3d ev = eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();  // ascending
  core::Require(
      ev(2) > 0 && ev(0) / ev(2) >= options.min_volume_ratio, where,
      fmt::format("the calibration points are (nearly) coplanar (thickness ratio {:.3g} < "
                  "{}); stage 1 needs points spanning a volume",
                  ev(2) > 0 ? ev(0) / ev(2) : 0.0, options.min_volume_ratio));

  const double dpx = prior.sensor.dpx_mm(), dpy = prior.sensor.dpy_mm();
  std::vector<Vector2d> s(n);  // (Xd' = Xd * sx, Yd), mm
  for (int i = 0; i < n; ++i) {
    s[i] = Vector2d((points[i].pixel.x() - cx_px) * dpx, (points[i].pixel.y() - cy_px) * dpy);
  }
  MatrixXd a(n, 7);
  VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    const Vector3d& p = points[i].target_mm;
    const double xd = s[i].x(), yd = s[i].y();
    a.row(i) << yd * p.x(), yd * p.y(), yd * p.z(), yd, -xd * p.x(), -xd * p.y(), -xd * p.z();
    b(i) = xd;
  }
  Eigen::JacobiSVD<MatrixXd> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const VectorXd sv = svd.singularValues();
  core::Require(sv(6) > 1e-12 * sv(0), where,
                "Tsai's linear system is singular (points degenerate for this view)");
  const VectorXd l = svd.solve(b);
  const double inv_ty = l.segment<3>(4).norm();
  core::Require(inv_ty > 0 && std::isfinite(inv_ty), where, "degenerate solution (ty)");
  double ty = 1.0 / inv_ty;
  const double sx = l.segment<3>(0).norm() * ty;
  // farthest point from the centre decides the sign of ty
  int far = 0;
  for (int i = 1; i < n; ++i) {
    if (s[i].squaredNorm() > s[far].squaredNorm()) far = i;
  }
  const Vector3d r1o = l.segment<3>(0) / sx;  // r1 / ty
  const double txo = l(3) / sx;               // tx / ty
  const Vector3d r2o = l.segment<3>(4);       // r2 / ty
  if (!TyIsPositive(r1o, r2o, txo, ty, points[far].target_mm, s[far])) ty = -ty;
  Matrix3d r;
  r.row(0) = r1o * ty;
  r.row(1) = r2o * ty;
  r.row(2) = r.row(0).cross(r.row(1));
  r = NearestRotation(r);
  const double tx = txo * ty;
  std::vector<Vector2d> sd(n);
  for (int i = 0; i < n; ++i) sd[i] = Vector2d(s[i].x() / sx, s[i].y());
  double f = 0, tz = 0;
  SolveFocalTzWithSign(&r, tx, ty, points, sd, where, &f, &tz);
  geometry::TsaiCamera cam = prior.Camera(f, cx_px, cy_px, sx);
  cam.rotation = r;
  cam.translation_mm = Vector3d(tx, ty, tz);
  RequireInFront(cam, points, where);
  return cam;
}

geometry::TsaiCamera CoplanarImpl(const geometry::TsaiCamera& intrinsics,
                                  const std::vector<Correspondence>& points, bool fix_focal,
                                  const TsaiInitOptions& options, const std::string& where) {
  const int n = static_cast<int>(points.size());
  core::Require(n >= options.min_points_coplanar, where,
                fmt::format("{} calibration points; the coplanar calibration needs at least {}", n,
                            options.min_points_coplanar));
  CheckFinite(points, where);
  double extent = 0.0;
  for (const auto& c : points) extent = std::max(extent, c.target_mm.head<2>().norm());
  for (const auto& c : points) {
    core::Require(std::abs(c.target_mm.z()) <= 1e-6 * std::max(1.0, extent), where,
                  fmt::format("point {} is not on the target plane z = 0 (z = {} mm)", c.id,
                              c.target_mm.z()));
  }
  const double dpx = intrinsics.sensor.dpx_mm(), dpy = intrinsics.sensor.dpy_mm();
  std::vector<Vector2d> s(n);  // undistorted sensor coordinates, mm
  for (int i = 0; i < n; ++i) {
    const Vector2d u = intrinsics.UndistortPixel(points[i].pixel);
    s[i] = Vector2d((u.x() - intrinsics.cx_px) * dpx / intrinsics.sx,
                    (u.y() - intrinsics.cy_px) * dpy);
  }
  MatrixXd a(n, 5);
  VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    const Vector3d& p = points[i].target_mm;
    const double xd = s[i].x(), yd = s[i].y();
    a.row(i) << yd * p.x(), yd * p.y(), yd, -xd * p.x(), -xd * p.y();
    b(i) = xd;
  }
  Eigen::JacobiSVD<MatrixXd> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
  core::Require(svd.singularValues()(4) > 1e-12 * svd.singularValues()(0), where,
                "Tsai's coplanar linear system is singular (points collinear or degenerate)");
  const VectorXd l = svd.solve(b);
  // ty^2 from the 2x2 upper-left block of R (Tsai 1987, eq. for the coplanar case).
  const double l1 = l(0), l2 = l(1), l3 = l(2), l4 = l(3), l5 = l(4);
  const double sr = l1 * l1 + l2 * l2 + l4 * l4 + l5 * l5;
  const double det = l1 * l5 - l4 * l2;
  double ty2;
  if (std::abs(det) > 1e-12 * sr) {
    ty2 = (sr - std::sqrt(std::max(0.0, sr * sr - 4 * det * det))) / (2 * det * det);
  } else {
    ty2 = 1.0 / std::max(l1 * l1 + l2 * l2, l4 * l4 + l5 * l5);  // a zero row/column
  }
  core::Require(ty2 > 0 && std::isfinite(ty2), where, "degenerate solution (ty)");
  double ty = std::sqrt(ty2);
  int far = 0;
  for (int i = 1; i < n; ++i) {
    if (s[i].squaredNorm() > s[far].squaredNorm()) far = i;
  }
  if (!TyIsPositive(Vector3d(l1, l2, 0), Vector3d(l4, l5, 0), l3, ty, points[far].target_mm,
                    s[far])) {
    ty = -ty;
  }
  const double r11 = l1 * ty, r12 = l2 * ty, r21 = l4 * ty, r22 = l5 * ty, tx = l3 * ty;
  const double r13 = std::sqrt(std::max(0.0, 1 - r11 * r11 - r12 * r12));
  const double r23 = (r11 * r21 + r12 * r22 >= 0 ? -1.0 : 1.0) *
                     std::sqrt(std::max(0.0, 1 - r21 * r21 - r22 * r22));
  Matrix3d r;
  r.row(0) = Vector3d(r11, r12, r13);
  r.row(1) = Vector3d(r21, r22, r23);
  r.row(2) = r.row(0).cross(r.row(1));
  r = NearestRotation(r);
  double f = 0, tz = 0;
  SolveFocalTzWithSign(&r, tx, ty, points, s, where, &f, &tz);
  geometry::TsaiCamera cam = intrinsics;
  if (fix_focal) {
    // tz with the known f: least squares of Yd tz = f yc - Yd w.
    f = intrinsics.focal_mm;
    double num = 0, den = 0;
    for (int i = 0; i < n; ++i) {
      const Vector3d& p = points[i].target_mm;
      const double yc = r.row(1).dot(p) + ty, w = r.row(2).dot(p);
      num += s[i].y() * (f * yc - s[i].y() * w);
      den += s[i].y() * s[i].y();
    }
    core::Require(den > 0, where, "degenerate solution (tz)");
    tz = num / den;
  }
  cam.focal_mm = f;
  cam.rotation = r;
  cam.translation_mm = Vector3d(tx, ty, tz);
  RequireInFront(cam, points, where);
  return cam;
}

}  // namespace

double ReprojectionErrorPx(const geometry::TsaiCamera& intrinsics, const View& view,
                           const Correspondence& c) {
  geometry::TsaiCamera cam = intrinsics;
  cam.rotation = view.rotation;
  cam.translation_mm = view.translation_mm;
  Vector2d px;
  if (!cam.Project(c.target_mm, &px)) return std::numeric_limits<double>::infinity();
  return (px - c.pixel).norm();
}

Vector2d DotCentroidOffsetPx(const geometry::TsaiCamera& intrinsics, const View& view,
                             const Vector3d& centre_mm, const Vector3d& normal, double radius_mm) {
  geometry::TsaiCamera cam = intrinsics;
  cam.rotation = view.rotation;
  cam.translation_mm = view.translation_mm;
  Vector2d centre_px;
  if (!cam.Project(centre_mm, &centre_px)) return Vector2d::Zero();
  // The outline as a polygon; the area centroid of a fine regular polygon is that of
  // the imaged disc to far below the detector's precision.
  const Vector3d u = normal.unitOrthogonal();
  const Vector3d v = normal.normalized().cross(u);
  constexpr int kSides = 48;
  Vector2d first, previous, sum = Vector2d::Zero();
  double area2 = 0.0;
  for (int k = 0; k <= kSides; ++k) {
    const double a = 2.0 * M_PI * (k % kSides) / kSides;
    Vector2d p;
    if (!cam.Project(centre_mm + radius_mm * (std::cos(a) * u + std::sin(a) * v), &p)) {
      return Vector2d::Zero();
    }
    p -= centre_px;  // relative, for precision
    if (k > 0) {
      const double cross = previous.x() * p.y() - p.x() * previous.y();
      area2 += cross;
      sum += cross * (previous + p);
    }
    previous = p;
  }
  if (std::abs(area2) < 1e-12) return Vector2d::Zero();
  return sum / (3.0 * area2);
}

void CorrectDotCentroids(const geometry::TsaiCamera& intrinsics, View* view) {
  for (auto& c : view->points) {
    if (c.marker_radius_mm <= 0) continue;
    c.pixel = c.detected_px - DotCentroidOffsetPx(intrinsics, *view, c.target_mm, c.marker_normal,
                                                  c.marker_radius_mm);
  }
}

namespace {

// The parameter vector: the free intrinsics, then per view a rotation vector (applied
// on the left of the view's starting rotation) and the translation.
struct Problem : Eigen::DenseFunctor<double> {
  Problem(const geometry::TsaiCamera& camera, const std::vector<View>& views,
          const RefineOptions& options, int inputs, int values)
      : Eigen::DenseFunctor<double>(inputs, values),
        camera(camera),
        views(views),
        options(options) {}

  const geometry::TsaiCamera& camera;
  const std::vector<View>& views;
  const RefineOptions& options;
  mutable std::vector<double> typical;  // per parameter, for the difference step

  // Writes x into a camera (intrinsics) and the views' poses.
  void Unpack(const VectorXd& x, geometry::TsaiCamera* cam, std::vector<View>* out) const {
    *cam = camera;
    int k = 0;
    if (options.refine_focal) cam->focal_mm = x(k++);
    if (options.refine_kappa1) cam->kappa1_per_mm2 = x(k++);
    if (options.refine_centre) {
      cam->cx_px = x(k++);
      cam->cy_px = x(k++);
    }
    if (options.refine_sx) cam->sx = x(k++);
    if (out) *out = views;
    for (size_t v = 0; v < views.size(); ++v) {
      if (!options.refine_poses) continue;
      const Vector3d w = x.segment<3>(k);
      const double angle = w.norm();
      const Matrix3d dr =
          angle > 0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix() : Matrix3d::Identity();
      if (out) {
        (*out)[v].rotation = dr * views[v].rotation;
        (*out)[v].translation_mm = x.segment<3>(k + 3);
      }
      k += 6;
    }
  }

  VectorXd Pack() const {
    std::vector<double> x;
    typical.clear();
    auto add = [&](double value, double scale) {
      x.push_back(value);
      typical.push_back(scale);
    };
    if (options.refine_focal) add(camera.focal_mm, std::max(1e-3, std::abs(camera.focal_mm)));
    if (options.refine_kappa1) add(camera.kappa1_per_mm2, 1e-3);
    if (options.refine_centre) {
      add(camera.cx_px, 1.0);
      add(camera.cy_px, 1.0);
    }
    if (options.refine_sx) add(camera.sx, 1.0);
    if (options.refine_poses) {
      for (const auto& v : views) {
        for (int i = 0; i < 3; ++i) add(0.0, 1.0);
        for (int i = 0; i < 3; ++i)
          add(v.translation_mm(i), std::max(1.0, v.translation_mm.norm()));
      }
    }
    return Eigen::Map<VectorXd>(x.data(), static_cast<int>(x.size()));
  }

  int operator()(const VectorXd& x, VectorXd& fvec) const {
    geometry::TsaiCamera cam;
    std::vector<View> posed;
    Unpack(x, &cam, &posed);
    int k = 0;
    for (const auto& view : posed) {
      cam.rotation = view.rotation;
      cam.translation_mm = view.translation_mm;
      for (const auto& c : view.points) {
        Vector2d px;
        if (cam.Project(c.target_mm, &px) && px.allFinite()) {
          fvec(k) = px.x() - c.pixel.x();
          fvec(k + 1) = px.y() - c.pixel.y();
        } else {
          fvec(k) = fvec(k + 1) = 1e6;  // behind the camera: a wall the solver backs off
        }
        k += 2;
      }
    }
    return 0;
  }

  // Central differences with a step relative to each parameter's typical size.
  int df(const VectorXd& x, MatrixXd& fjac) const {
    VectorXd xp = x, fp(values()), fm(values());
    for (int j = 0; j < inputs(); ++j) {
      const double h = 1e-6 * typical[j];
      xp(j) = x(j) + h;
      (*this)(xp, fp);
      xp(j) = x(j) - h;
      (*this)(xp, fm);
      xp(j) = x(j);
      fjac.col(j) = (fp - fm) / (2 * h);
    }
    return 0;
  }
};

}  // namespace

std::string RefineSummary::BriefReport() const {
  return fmt::format(
      "LM: {} iterations, {} evaluations, {} parameters, {} residuals, RMS {:.4f} -> "
      "{:.4f} px{}",
      iterations, function_evaluations, parameters, residuals, initial_rms_px, final_rms_px,
      converged ? "" : " (not converged)");
}

RefineSummary RefineCamera(geometry::TsaiCamera* camera, std::vector<View>* views,
                           const RefineOptions& options, const std::string& where) {
  options.Check();
  int residuals = 0;
  for (const auto& v : *views) residuals += 2 * static_cast<int>(v.points.size());
  const int intrinsics =
      options.refine_focal + options.refine_kappa1 + 2 * options.refine_centre + options.refine_sx;
  const int parameters =
      intrinsics + (options.refine_poses ? 6 * static_cast<int>(views->size()) : 0);
  core::Require(parameters > 0, where, "nothing to refine");
  core::Require(residuals >= parameters + 1, where,
                fmt::format("{} image coordinates for {} free parameters; too few points",
                            residuals, parameters));
  Problem problem(*camera, *views, options, parameters, residuals);
  VectorXd x = problem.Pack();
  VectorXd f(residuals);
  problem(x, f);
  RefineSummary summary;
  summary.parameters = parameters;
  summary.residuals = residuals;
  summary.initial_rms_px = std::sqrt(f.squaredNorm() / (residuals / 2));

  Eigen::LevenbergMarquardt<Problem> lm(problem);
  lm.setMaxfev(options.max_function_evaluations);
  lm.setXtol(1e-12);
  lm.setFtol(1e-12);
  lm.setGtol(0.0);
  const auto status = lm.minimize(x);
  summary.iterations = static_cast<int>(lm.iterations());
  summary.function_evaluations = static_cast<int>(lm.nfev());
  summary.converged = status != Eigen::LevenbergMarquardtSpace::TooManyFunctionEvaluation &&
                      status != Eigen::LevenbergMarquardtSpace::ImproperInputParameters;

  problem(x, f);
  summary.final_rms_px = std::sqrt(f.squaredNorm() / (residuals / 2));
  // Covariance (J^T J)^-1 s^2, s^2 = SSR / (m - n).
  MatrixXd jac(residuals, parameters);
  problem.df(x, jac);
  const MatrixXd jtj = jac.transpose() * jac;
  Eigen::LDLT<MatrixXd> ldlt(jtj);
  const double s2 = f.squaredNorm() / std::max(1, residuals - parameters);
  if (ldlt.info() == Eigen::Success) {
    const MatrixXd cov = ldlt.solve(MatrixXd::Identity(parameters, parameters)) * s2;
    auto sd = [&](int k) { return std::sqrt(std::max(0.0, cov(k, k))); };
    int k = 0;
    if (options.refine_focal) summary.sigma.focal_mm = sd(k++);
    if (options.refine_kappa1) summary.sigma.kappa1_per_mm2 = sd(k++);
    if (options.refine_centre) {
      summary.sigma.cx_px = sd(k++);
      summary.sigma.cy_px = sd(k++);
    }
    if (options.refine_sx) summary.sigma.sx = sd(k++);
    if (options.refine_poses && !views->empty()) {
      const int base = intrinsics + 6 * (static_cast<int>(views->size()) - 1);
      for (int i = 0; i < 3; ++i) {
        summary.sigma.rotation_deg(i) = sd(base + i) * 180.0 / M_PI;
        summary.sigma.translation_mm(i) = sd(base + 3 + i);
      }
    }
  }
  std::vector<View> posed;
  geometry::TsaiCamera cam;
  problem.Unpack(x, &cam, &posed);
  cam.rotation = camera->rotation;
  cam.translation_mm = camera->translation_mm;
  *camera = cam;
  *views = posed;
  return summary;
}

}  // namespace dome::calib
