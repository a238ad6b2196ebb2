// Synthetic scenes for stereo tests: pinhole cameras looking down +z at a textured
// fronto-parallel plane, images rendered exactly (bilinear texture lookup).
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "geometry/tsai_camera.h"
#include "stereo/multi_baseline.h"

namespace dome::stereo::testing {

// Camera with focal `f_px` pixels, centre at world (cx_mm, cy_mm, 0), looking down +z.
inline geometry::TsaiCamera PlaneCamera(const std::string& id, double cx_mm, double cy_mm,
                                        int width = 160, int height = 120, double f_px = 200.0) {
  geometry::TsaiCamera c;
  c.id = id;
  c.width_px = width;
  c.height_px = height;
  c.sensor = {double(width), double(width), 0.01, 0.01};
  c.focal_mm = f_px * 0.01;
  c.cx_px = (width - 1) / 2.0;
  c.cy_px = (height - 1) / 2.0;
  c.translation_mm = Eigen::Vector3d(-cx_mm, -cy_mm, 0.0);  // camera = world + t
  return c;
}

// A random texture (blurred noise, 0..255), `texel_mm` millimetres per texel, centred
// on the optical axis of the first camera.
inline cv::Mat MakeTexture(int size, uint64_t seed) {
  cv::Mat t(size, size, CV_32FC1);
  cv::RNG rng(seed);
  rng.fill(t, cv::RNG::UNIFORM, 0.0, 255.0);
  cv::GaussianBlur(t, t, cv::Size(0, 0), 1.2);
  cv::normalize(t, t, 10, 245, cv::NORM_MINMAX);
  return t;
}

// Renders what `cam` sees of the plane z = plane_mm textured by `texture`.
inline cv::Mat RenderPlane(const geometry::TsaiCamera& cam, double plane_mm, const cv::Mat& texture,
                           double texel_mm) {
  cv::Mat mx(cam.height_px, cam.width_px, CV_32FC1), my(cam.height_px, cam.width_px, CV_32FC1);
  for (int y = 0; y < cam.height_px; ++y) {
    for (int x = 0; x < cam.width_px; ++x) {
      const Eigen::Vector3d p = cam.BackProjectAtDepth(Eigen::Vector2d(x, y), 1.0);
      const Eigen::Vector3d c = cam.CentreWorld();
      const double s = (plane_mm - c.z()) / (p.z() - c.z());
      const Eigen::Vector3d X = c + s * (p - c);
      mx.at<float>(y, x) = float(X.x() / texel_mm + texture.cols / 2.0);
      my.at<float>(y, x) = float(X.y() / texel_mm + texture.rows / 2.0);
    }
  }
  cv::Mat out;
  cv::remap(texture, out, mx, my, cv::INTER_CUBIC, cv::BORDER_REFLECT);
  cv::Mat out8;
  out.convertTo(out8, CV_8UC1);
  return out8;
}

// A reference camera at the origin and one neighbour per centre offset (mm), all
// `width` x `height` with focal `f_px`, seeing the plane z = plane_mm: textured by
// MakeTexture(1024, seed) at `texel_mm` per texel, or uniform grey 128 (textureless).
inline StereoInput PlaneStereoInput(double plane_mm, bool textured,
                                    const std::vector<Eigen::Vector2d>& offsets_mm, double texel_mm,
                                    uint64_t seed, int width = 160, int height = 120,
                                    double f_px = 200.0) {
  const cv::Mat texture = MakeTexture(1024, seed);
  StereoInput in;
  in.reference.camera = PlaneCamera("ref", 0, 0, width, height, f_px);
  int k = 0;
  for (const Eigen::Vector2d& o : offsets_mm) {
    StereoView v;
    v.camera = PlaneCamera("n" + std::to_string(k++), o.x(), o.y(), width, height, f_px);
    in.neighbours.push_back(v);
  }
  auto render = [&](const geometry::TsaiCamera& c) {
    return textured ? RenderPlane(c, plane_mm, texture, texel_mm)
                    : cv::Mat(c.height_px, c.width_px, CV_8UC1, cv::Scalar(128));
  };
  in.reference.image = render(in.reference.camera);
  for (auto& v : in.neighbours) v.image = render(v.camera);
  return in;
}

}  // namespace dome::stereo::testing
