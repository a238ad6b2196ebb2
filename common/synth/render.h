// Rendering a dome camera's view the way the seed's cameras and digitizer made it.
//
// Each frame sample is one ray, cast exactly (synth/ray_caster.h) through the sample's
// position on the Tsai camera (distortion included), and shaded Lambertian
// (synth/texture.h). The camera turns radiance into a grey level:
//   value = clamp(round(gain * radiance + offset + noise_sigma * n), 0, 255),
// n a standard normal deviate that depends only on (noise_key, sample) -- the only
// thing the user's seed changes.
//
// The NTSC frame (seed §4.2) is 2W x 2H samples: its even rows (0, 2, ...) are the first
// field, exposed at the instant's time t; its odd rows the second field, exposed at
// t + 1/60 s, so anything that moves is displaced between the two (the seed's Figure 10).
// The take image keeps the first field and averages column pairs:
//   image(y, x) = (frame(2y, 2x) + frame(2y, 2x + 1) + 1) / 2   (integer division).
// In the take image's pixel coordinates (those of the rig camera, synth/dome_rig.h),
// frame sample (column j, row r) lies at ((j - 0.5) / 2, r / 2); so the two samples of
// image pixel (x, y) are at (x -+ 0.25, y).
//
// The truth depth map has one ray per take-image pixel centre (x, y) at the first
// field's time: z-depth along the optical axis in mm (camera-frame z of the hit), 0
// where the ray hits nothing -- the encoding of every dome depth map (io/depth_tiff.h).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>

#include "geometry/tsai_camera.h"
#include "synth/dome_rig.h"
#include "synth/ray_caster.h"
#include "synth/texture.h"

namespace dome::synth {

// Rays of a Tsai camera, by take-image pixel coordinates.
class CameraRays {
 public:
  explicit CameraRays(const geometry::TsaiCamera& camera);
  // World-frame direction through pixel (x, y) whose camera-frame z component is 1:
  // the ray parameter t of a hit is its z-depth in mm.
  Eigen::Vector3d Direction(double x_px, double y_px) const;
  const Eigen::Vector3d& origin() const { return origin_; }

 private:
  Eigen::Matrix3d camera_to_world_;
  Eigen::Vector3d origin_;
  double cx_, cy_, dpx_over_sx_, dpy_, kappa1_, inv_focal_;
};

// The shaded radiance of a hit seen along `direction` (any length): Lambertian with
// the interpolated vertex normal, turned towards the viewer (two-sided surfaces).
double HitRadiance(const SceneMesh& mesh, const Lighting& lighting, const Eigen::Vector3d& origin,
                   const Eigen::Vector3d& direction, const RayHit& hit);

// Grey level of a radiance through a camera response, with noise deviate n.
inline uint8_t SensorValue(const CameraResponse& response, double radiance, double n) {
  const double v = response.gain * radiance + response.offset + response.noise_sigma * n;
  const double r = v < 0.0 ? 0.0 : (v > 255.0 ? 255.0 : v);
  return static_cast<uint8_t>(static_cast<int>(r + 0.5));
}

struct RenderedView {
  cv::Mat frame;      // CV_8UC1, 2H x 2W: the interlaced NTSC frame (tape)
  cv::Mat image;      // CV_8UC1, H x W: the take image (first field, column pairs averaged)
  cv::Mat depth_mm;   // CV_32FC1, H x W: truth z-depth of the first field, 0 = no surface
  cv::Mat on_person;  // CV_8UC1, 2H x 2W: 255 where the frame sample's ray hits the person
  cv::Mat person;     // CV_8UC1, H x W, with person_mask: the take image's truth foreground
                      // mask, 255 where the person is at least half of the pixel, i.e. where
                      // either of the two first-field samples averaged into it hits the
                      // person (a pixel the person touches that much belongs to its
                      // silhouette: a visual hull must not shave it off)
};

struct RenderRequest {
  const geometry::TsaiCamera* camera = nullptr;  // the take image's camera
  CameraResponse response;
  const RayCaster* first_field = nullptr;   // the scene at t
  const RayCaster* second_field = nullptr;  // the scene at t + 1/60 s (may equal first_field)
  const Lighting* lighting = nullptr;
  uint64_t noise_key = 0;    // identifies the image; see NoiseKey
  bool depth = true;         // compute depth_mm
  bool person_mask = false;  // compute on_person and person
};

RenderedView RenderView(const RenderRequest& request);

// The truth depth map alone (CV_32FC1, H x W): the z-depth in mm of the surface at
// each take-image pixel centre, 0 where the ray hits nothing.
cv::Mat TruthDepth(const geometry::TsaiCamera& camera, const RayCaster& caster);

// The noise key of one image: a hash of the user's seed and the image's identity.
uint64_t NoiseKey(uint64_t seed, uint64_t kind, uint64_t instant, uint64_t camera);

// Take-image pixel coordinates of frame sample (column j, row r).
inline Eigen::Vector2d FrameSampleToImage(int j, int r) { return {(j - 0.5) / 2.0, r / 2.0}; }

}  // namespace dome::synth
