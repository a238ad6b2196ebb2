#include "fusion/consistency.h"

#include <cmath>
#include <string>

#include "core/error.h"
#include "core/parallel_for.h"

namespace dome::fusion {

void ConsistencyOptions::Check() const {
  core::Require(min_views >= 1, "fusion: min_consistent_views",
                "must be at least 1, got " + std::to_string(min_views));
  core::Require(std::isfinite(tolerance_mm) && tolerance_mm > 0.0,
                "fusion: consistency_tolerance_mm",
                "must be a positive number of mm, got " + std::to_string(tolerance_mm));
}

std::vector<cv::Mat> KeepConsistentDepth(const std::vector<RangeImage>& images,
                                         const ConsistencyOptions& options) {
  options.Check();
  for (const RangeImage& image : images) CheckRangeImage(image);
  // Images grouped by camera id, in first-seen order.
  std::vector<std::vector<int>> groups;
  std::vector<int> group_of(images.size(), -1);
  for (size_t i = 0; i < images.size(); ++i) {
    for (size_t g = 0; g < groups.size() && group_of[i] < 0; ++g) {
      if (images[groups[g][0]].camera.id == images[i].camera.id) {
        groups[g].push_back(int(i));
        group_of[i] = int(g);
      }
    }
    if (group_of[i] < 0) {
      group_of[i] = int(groups.size());
      groups.push_back({int(i)});
    }
  }
  std::vector<cv::Mat> out(images.size());
  const float tolerance = static_cast<float>(options.tolerance_mm);
  const int threads = options.num_threads > 0 ? options.num_threads : core::HardwareThreads();
  for (size_t a = 0; a < images.size(); ++a) {
    const RangeImage& image = images[a];
    const geometry::TsaiCamera self = image.PixelCamera();
    std::vector<geometry::TsaiCamera> group_cams;
    for (const auto& group : groups) group_cams.push_back(images[group[0]].PixelCamera());
    out[a] = image.depth_mm.clone();
    cv::Mat& depth = out[a];
    core::ParallelFor(0, depth.rows, threads, [&](int64_t y0, int64_t y1) {
      for (int64_t y = y0; y < y1; ++y) {
        float* row = depth.ptr<float>(int(y));
        for (int x = 0; x < depth.cols; ++x) {
          if (!(row[x] > 0.0f)) continue;
          const Eigen::Vector3d world =
              self.BackProjectAtDepth(Eigen::Vector2d(x, double(y)), row[x]);
          int agree = 0;
          for (size_t g = 0; g < groups.size() && agree < options.min_views; ++g) {
            if (int(g) == group_of[a]) continue;
            const geometry::TsaiCamera& cam = group_cams[g];
            const Eigen::Vector3d q = cam.WorldToCamera(world);
            Eigen::Vector2d pixel;
            if (!cam.ProjectCamera(q, &pixel)) continue;
            const double u = std::round(pixel.x()), v = std::round(pixel.y());
            if (!(u >= 0 && v >= 0 && u < cam.width_px && v < cam.height_px)) continue;
            for (int b : groups[g]) {
              const float d = images[b].depth_mm.at<float>(int(v), int(u));
              if (d > 0.0f && std::abs(d - float(q.z())) <= tolerance) {
                ++agree;
                break;
              }
            }
          }
          if (agree < options.min_views) row[x] = 0.0f;
        }
      }
    });
  }
  return out;
}

}  // namespace dome::fusion
