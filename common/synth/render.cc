#include "synth/render.h"

#include <algorithm>
#include <vector>

#include "core/error.h"
#include "synth/noise.h"

namespace dome::synth {

CameraRays::CameraRays(const geometry::TsaiCamera& camera)
    : camera_to_world_(camera.rotation.transpose()),
      origin_(-camera.rotation.transpose() * camera.translation_mm),
      cx_(camera.cx_px),
      cy_(camera.cy_px),
      dpx_over_sx_(camera.sensor.dpx_mm() / camera.sx),
      dpy_(camera.sensor.dpy_mm()),
      kappa1_(camera.kappa1_per_mm2),
      inv_focal_(1.0 / camera.focal_mm) {}

Eigen::Vector3d CameraRays::Direction(double x_px, double y_px) const {
  // Tsai: pixel -> distorted sensor point -> undistorted (closed form) -> ray.
  const double xd = (x_px - cx_) * dpx_over_sx_;
  const double yd = (y_px - cy_) * dpy_;
  const double factor = 1.0 + kappa1_ * (xd * xd + yd * yd);
  const Eigen::Vector3d camera_dir(xd * factor * inv_focal_, yd * factor * inv_focal_, 1.0);
  return camera_to_world_ * camera_dir;
}

double HitRadiance(const SceneMesh& mesh, const Lighting& lighting, const Eigen::Vector3d& origin,
                   const Eigen::Vector3d& direction, const RayHit& hit) {
  const Eigen::Vector3i& f = mesh.faces[hit.face];
  const double w0 = 1.0 - hit.u - hit.v;
  Eigen::Vector3d normal = w0 * mesh.normals[f[0]].cast<double>() +
                           hit.u * mesh.normals[f[1]].cast<double>() +
                           hit.v * mesh.normals[f[2]].cast<double>();
  const double len = normal.norm();
  normal = len > 0 ? Eigen::Vector3d(normal / len) : Eigen::Vector3d::UnitZ();
  if (normal.dot(direction) > 0.0) normal = -normal;
  const Part& part = mesh.parts[mesh.face_part[hit.face]];
  const Eigen::Vector3d point = origin + static_cast<double>(hit.t) * direction;
  return lighting.Radiance(Albedo(part.material, part.ToLocal(point)), normal);
}

uint64_t NoiseKey(uint64_t seed, uint64_t kind, uint64_t instant, uint64_t camera) {
  return HashKey(HashKey(HashKey(Mix64(seed), kind), instant), camera);
}

RenderedView RenderView(const RenderRequest& request) {
  DOME_CHECK(request.camera != nullptr && request.first_field != nullptr &&
                 request.second_field != nullptr && request.lighting != nullptr,
             "incomplete RenderRequest");
  const geometry::TsaiCamera& camera = *request.camera;
  const int width = camera.width_px, height = camera.height_px;
  const int frame_width = 2 * width, frame_height = 2 * height;
  const CameraRays rays(camera);
  const Eigen::Vector3d origin = rays.origin();
  const Eigen::Vector3f origin_f = origin.cast<float>();
  const Lighting& lighting = *request.lighting;
  const GaussianSampler gaussian;
  const bool noisy = request.response.noise_sigma > 0.0;

  RenderedView view;
  view.frame.create(frame_height, frame_width, CV_8UC1);
  if (request.person_mask) view.on_person = cv::Mat::zeros(frame_height, frame_width, CV_8UC1);
  std::vector<Eigen::Vector3d> dirs(frame_width);
  std::vector<Eigen::Vector3f> dirs_f(frame_width);
  std::vector<RayHit> hits(frame_width);
  for (int r = 0; r < frame_height; ++r) {
    const RayCaster& caster = (r % 2 == 0) ? *request.first_field : *request.second_field;
    const SceneMesh& mesh = caster.mesh();
    for (int j = 0; j < frame_width; ++j) {
      const Eigen::Vector2d p = FrameSampleToImage(j, r);
      dirs[j] = rays.Direction(p.x(), p.y());
      dirs_f[j] = dirs[j].cast<float>();
    }
    caster.IntersectMany(origin_f, dirs_f.data(), frame_width, hits.data());
    uint8_t* row = view.frame.ptr<uint8_t>(r);
    for (int j = 0; j < frame_width; ++j) {
      const RayHit& hit = hits[j];
      double radiance = lighting.sky_radiance;
      if (hit.face != RayHit::kNoFace) {
        radiance = HitRadiance(mesh, lighting, origin, dirs[j], hit);
        if (request.person_mask && mesh.parts[mesh.face_part[hit.face]].on_person) {
          view.on_person.at<uint8_t>(r, j) = 255;
        }
      }
      const uint64_t sample = static_cast<uint64_t>(r) * frame_width + j;
      const double n = noisy ? gaussian(HashKey(request.noise_key, sample)) : 0.0;
      row[j] = SensorValue(request.response, radiance, n);
    }
  }
  view.image.create(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y) {
    const uint8_t* src = view.frame.ptr<uint8_t>(2 * y);
    uint8_t* dst = view.image.ptr<uint8_t>(y);
    for (int x = 0; x < width; ++x) {
      dst[x] = static_cast<uint8_t>((src[2 * x] + src[2 * x + 1] + 1) / 2);
    }
  }
  if (request.person_mask) {
    // The take image's truth mask from the same two first-field samples as its pixels.
    view.person.create(height, width, CV_8UC1);
    for (int y = 0; y < height; ++y) {
      const uint8_t* src = view.on_person.ptr<uint8_t>(2 * y);
      uint8_t* dst = view.person.ptr<uint8_t>(y);
      for (int x = 0; x < width; ++x) dst[x] = std::max(src[2 * x], src[2 * x + 1]);
    }
  }
  if (request.depth) {
    view.depth_mm = TruthDepth(camera, *request.first_field);
  }
  return view;
}

cv::Mat TruthDepth(const geometry::TsaiCamera& camera, const RayCaster& caster) {
  const CameraRays rays(camera);
  const Eigen::Vector3f origin = rays.origin().cast<float>();
  cv::Mat depth(camera.height_px, camera.width_px, CV_32FC1);
  std::vector<Eigen::Vector3f> dirs(camera.width_px);
  std::vector<RayHit> hits(camera.width_px);
  for (int y = 0; y < camera.height_px; ++y) {
    for (int x = 0; x < camera.width_px; ++x) dirs[x] = rays.Direction(x, y).cast<float>();
    caster.IntersectMany(origin, dirs.data(), camera.width_px, hits.data());
    float* dst = depth.ptr<float>(y);
    for (int x = 0; x < camera.width_px; ++x) {
      dst[x] = hits[x].face == RayHit::kNoFace ? 0.0f : hits[x].t;
    }
  }
  return depth;
}

}  // namespace dome::synth
