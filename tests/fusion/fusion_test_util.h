// Test scenes for fusion and meshing: analytic spheres seen by look-at Tsai cameras,
// exact depth maps by ray casting (z along the optical axis, mm, 0 = no surface).
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fusion/integrate.h"
#include "geometry/tsai_camera.h"

namespace dome::testing {

struct Sphere {
  Eigen::Vector3d centre_mm;
  double radius_mm;
};

// A camera at `centre` looking at `target`, world z up; `fov_deg` horizontal.
inline geometry::TsaiCamera LookAtCamera(const std::string& id, const Eigen::Vector3d& centre,
                                         const Eigen::Vector3d& target, int width, int height,
                                         double fov_deg = 60.0, double kappa1 = 0.05) {
  geometry::TsaiCamera cam;
  cam.id = id;
  cam.width_px = width;
  cam.height_px = height;
  cam.sensor = {double(width), double(width), 0.01, 0.01};
  cam.focal_mm = 0.5 * width * 0.01 / std::tan(0.5 * fov_deg * M_PI / 180.0);
  cam.kappa1_per_mm2 = kappa1;
  cam.cx_px = 0.5 * (width - 1) + 0.3;
  cam.cy_px = 0.5 * (height - 1) - 0.2;
  const Eigen::Vector3d forward = (target - centre).normalized();
  Eigen::Vector3d up(0, 0, 1);
  if (std::abs(forward.dot(up)) > 0.99) up = Eigen::Vector3d(0, 1, 0);
  const Eigen::Vector3d right = forward.cross(up).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  cam.rotation.row(0) = right;
  cam.rotation.row(1) = down;
  cam.rotation.row(2) = forward;
  cam.translation_mm = -cam.rotation * centre;
  return cam;
}

// The first sphere the ray from `o` along the unit `d` enters (its index, -1 for none)
// and the distance to it along the ray (*t, mm).
inline int NearestSphere(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                         const std::vector<Sphere>& spheres, double* t) {
  double best = std::numeric_limits<double>::infinity();
  int hit = -1;
  for (size_t k = 0; k < spheres.size(); ++k) {
    const Eigen::Vector3d oc = o - spheres[k].centre_mm;
    const double b = oc.dot(d), c = oc.squaredNorm() - spheres[k].radius_mm * spheres[k].radius_mm;
    const double disc = b * b - c;
    if (disc < 0) continue;
    const double near = -b - std::sqrt(disc);
    if (near > 0 && near < best) best = near, hit = int(k);
  }
  *t = best;
  return hit;
}

// Exact z-depth of the nearest sphere per pixel.
inline cv::Mat RenderSpheres(const geometry::TsaiCamera& cam, const std::vector<Sphere>& spheres) {
  cv::Mat depth(cam.height_px, cam.width_px, CV_32FC1, cv::Scalar(0));
  const Eigen::Vector3d o = cam.CentreWorld();
  for (int y = 0; y < cam.height_px; ++y) {
    for (int x = 0; x < cam.width_px; ++x) {
      const Eigen::Vector3d d = cam.BackProject(Eigen::Vector2d(x, y));
      double t = 0;
      if (NearestSphere(o, d, spheres, &t) >= 0)
        depth.at<float>(y, x) = float(cam.WorldToCamera(o + t * d).z());
    }
  }
  return depth;
}

// Spheres stacked along z (for a tall, thin volume of many planes), seen by `n`
// cameras on a ring of radius 1500 mm at three heights.
inline std::vector<Sphere> StackedSpheres() {
  std::vector<Sphere> s;
  for (int m = 0; m < 6; ++m) s.push_back({Eigen::Vector3d(0, 0, 250 + 500 * m), 110.0});
  return s;
}

// `kappa1` 0.05 bends the image corners by about 20 %, far more than real lenses (the
// fusion kernel then reads its distortion table; real lenses give it a polynomial).
// The depth maps are rendered through the lens (distorted_pixels), as the synthetic
// truth is; with `ideal_pixels` through the camera without it, as stereo writes them.
inline std::vector<fusion::RangeImage> RingImages(const std::vector<Sphere>& spheres, int n,
                                                  int width, int height,
                                                  const std::vector<double>& heights_mm,
                                                  double kappa1 = 0.05, bool ideal_pixels = false) {
  std::vector<fusion::RangeImage> images;
  for (int c = 0; c < n; ++c) {
    const double a = 2 * M_PI * c / n;
    const double h = heights_mm[c % heights_mm.size()];
    const Eigen::Vector3d centre(1500 * std::cos(a), 1500 * std::sin(a), h);
    fusion::RangeImage image;
    image.camera = LookAtCamera("c" + std::to_string(c), centre, Eigen::Vector3d(0, 0, h), width,
                                height, 60.0, kappa1);
    geometry::TsaiCamera render = image.camera;
    if (ideal_pixels) render.kappa1_per_mm2 = 0.0;
    image.depth_mm = RenderSpheres(render, spheres);
    image.distorted_pixels = !ideal_pixels;
    image.where = "depth/c" + std::to_string(c) + ".tiff";
    images.push_back(image);
  }
  return images;
}

}  // namespace dome::testing
