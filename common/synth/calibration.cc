#include "synth/calibration.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "synth/noise.h"
#include "synth/render.h"

namespace dome::synth {

using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {
constexpr uint64_t kBenchStream = 0xbe4c4ca1b5ULL;
constexpr double kDeg = M_PI / 180.0;
}  // namespace

void Stage1Pose(const geometry::TsaiCamera& camera, int camera_index, int pose, Matrix3d* rotation,
                Vector3d* translation) {
  DOME_CHECK(pose >= 0 && pose < kStage1Poses, "Stage1Pose: pose out of range");
  const uint64_t stream = HashKey(kBenchStream, static_cast<uint64_t>(camera_index));
  Rng rng(pose == 0 ? stream : HashKey(stream, static_cast<uint64_t>(pose)));
  const Vector3d look_at(280, 280, 280);
  const Vector3d view =
      (Vector3d(1, 1, 1).normalized() +
       Vector3d(rng.Uniform(-0.15, 0.15), rng.Uniform(-0.15, 0.15), rng.Uniform(-0.15, 0.15)))
          .normalized();
  const double roll = rng.Uniform(-8.0, 8.0) * (pose == 0 ? 1.0 : 2.5) * kDeg;
  const Vector3d z = -view;
  const Vector3d down(0, 0, -1);
  const Vector3d y0 = (down - down.dot(z) * z).normalized();
  const Vector3d x0 = y0.cross(z);
  Matrix3d r;
  r.row(0) = std::cos(roll) * x0 + std::sin(roll) * y0;
  r.row(1) = -std::sin(roll) * x0 + std::cos(roll) * y0;
  r.row(2) = z;
  // Poses 1..4: the look-at point imaged towards image corner 1..4 (a turn of the
  // camera frame that takes its axis to that direction), so the dots reach the corner.
  Eigen::Vector2d offset_px = Eigen::Vector2d::Zero();
  if (pose > 0) {
    constexpr double kCornerward = 0.55;  // of the image's half width / height
    const double qx = (pose == 1 || pose == 4) ? -1.0 : 1.0;
    const double qy = pose <= 2 ? -1.0 : 1.0;
    offset_px = {qx * kCornerward * 0.5 * camera.width_px,
                 qy * kCornerward * 0.5 * camera.height_px};
    const Vector3d direction(offset_px.x() * camera.sensor.dpx_mm() / camera.sx / camera.focal_mm,
                             offset_px.y() * camera.sensor.dpy_mm() / camera.focal_mm, 1.0);
    r = Eigen::Quaterniond::FromTwoVectors(Vector3d::UnitZ(), direction).toRotationMatrix() * r;
  }
  *rotation = r;

  geometry::TsaiCamera probe = camera;
  probe.rotation = r;
  const double s = kPlateSizeMm;
  const Vector3d corners[] = {{0, 0, 0}, {s, 0, 0}, {0, s, 0}, {0, 0, s},
                              {s, s, 0}, {s, 0, s}, {0, s, s}};
  const Eigen::Vector2d aim(camera.cx_px + offset_px.x(), camera.cy_px + offset_px.y());
  double distance = 2000.0;
  for (int iteration = 0; iteration < 8; ++iteration) {
    const Vector3d centre = look_at + distance * view;
    probe.translation_mm = -r * centre;
    double fill = 0.0;
    for (const auto& c : corners) {
      Eigen::Vector2d px;
      if (!probe.Project(c, &px)) continue;
      fill = std::max(fill, std::abs(px.x() - aim.x()) / (0.5 * camera.width_px));
      fill = std::max(fill, std::abs(px.y() - aim.y()) / (0.5 * camera.height_px));
    }
    if (fill <= 0.0) break;
    distance *= fill / 0.9;  // image extent ~ 1 / distance
  }
  *translation = -r * (look_at + distance * view);
}

std::vector<ImagePoint> TrueImagePoints(const geometry::TsaiCamera& camera,
                                        const std::vector<TargetPoint>& points,
                                        double marker_radius_mm, const RayCaster& caster) {
  std::vector<ImagePoint> out;
  const CameraRays rays(camera);
  const double fx = camera.focal_mm * camera.sx / camera.sensor.dpx_mm();
  for (const auto& point : points) {
    const Vector3d c = camera.WorldToCamera(point.position_mm);
    Eigen::Vector2d px;
    if (!camera.Project(point.position_mm, &px)) continue;
    const double margin = marker_radius_mm * fx / c.z();
    if (px.x() < -0.5 + margin || px.x() > camera.width_px - 0.5 - margin ||
        px.y() < -0.5 + margin || px.y() > camera.height_px - 0.5 - margin) {
      continue;
    }
    RayHit hit;
    const Vector3d dir = rays.Direction(px.x(), px.y());
    if (!caster.Intersect(rays.origin().cast<float>(), dir.cast<float>(), &hit)) continue;
    if (std::abs(hit.t - c.z()) > 1.0 + 1e-4 * c.z()) continue;  // hidden
    out.push_back({point.id, px});
  }
  return out;
}

}  // namespace dome::synth
