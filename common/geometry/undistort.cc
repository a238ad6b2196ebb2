#include "geometry/undistort.h"

#include <deque>
#include <map>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <string>

#include "core/error.h"
#include "core/parallel_for.h"

namespace dome::geometry {
namespace {

std::string CameraWhere(const TsaiCamera& camera) { return "camera '" + camera.id + "'"; }

// Fills the tables row by row; rows are independent, so they are split over threads.
template <typename SourceOf>
RemapTables BuildTables(const TsaiCamera& camera, const SourceOf& source_of) {
  camera.Check(CameraWhere(camera));
  RemapTables tables;
  tables.map_x.create(camera.height_px, camera.width_px, CV_32FC1);
  tables.map_y.create(camera.height_px, camera.width_px, CV_32FC1);
  core::ParallelFor(0, camera.height_px, 0, [&](int64_t row_begin, int64_t row_end) {
    for (int64_t row = row_begin; row < row_end; ++row) {
      float* map_x = tables.map_x.ptr<float>(static_cast<int>(row));
      float* map_y = tables.map_y.ptr<float>(static_cast<int>(row));
      for (int col = 0; col < camera.width_px; ++col) {
        Eigen::Vector2d source;
        if (source_of(Eigen::Vector2d(col, static_cast<double>(row)), &source)) {
          map_x[col] = static_cast<float>(source.x());
          map_y[col] = static_cast<float>(source.y());
        } else {
          map_x[col] = -1.0f;  // far enough outside for BORDER_CONSTANT to give 0
          map_y[col] = -1.0f;
        }
      }
    }
  });
  tables.covered = Remap(cv::Mat(tables.map_x.size(), CV_8UC1, cv::Scalar(255)), tables);
  return tables;
}

void RequireImageSize(const TsaiCamera& camera, const cv::Mat& image, const char* which) {
  core::Require(!image.empty(), CameraWhere(camera), std::string(which) + " image is empty");
  core::Require(image.cols == camera.width_px && image.rows == camera.height_px,
                CameraWhere(camera),
                std::string(which) + " image is " + std::to_string(image.cols) + "x" +
                    std::to_string(image.rows) + ", the camera is " +
                    std::to_string(camera.width_px) + "x" + std::to_string(camera.height_px));
}

}  // namespace

RemapTables BuildUndistortTables(const TsaiCamera& camera) {
  return BuildTables(camera, [&camera](const Eigen::Vector2d& ideal, Eigen::Vector2d* source) {
    return camera.DistortPixelIfInRange(ideal, source);
  });
}

std::shared_ptr<const RemapTables> SharedUndistortTables(const TsaiCamera& camera) {
  const std::string key = camera.IntrinsicsKey();
  static std::mutex mutex;
  static std::map<std::string, std::shared_ptr<const RemapTables>> cache;
  static std::deque<std::string> order;  // oldest first
  static size_t bytes = 0;
  constexpr size_t kMaxBytes = size_t(512) << 20;
  {
    std::lock_guard<std::mutex> lock(mutex);
    auto it = cache.find(key);
    if (it != cache.end()) return it->second;
  }
  // Built outside the lock; two threads building the same tables keep the first.
  auto tables = std::make_shared<const RemapTables>(BuildUndistortTables(camera));
  const auto held = [](const RemapTables& t) {
    return 2 * t.map_x.total() * t.map_x.elemSize() + t.covered.total();
  };
  const size_t size = held(*tables);
  std::lock_guard<std::mutex> lock(mutex);
  auto [it, fresh] = cache.try_emplace(key, tables);
  if (!fresh) return it->second;
  order.push_back(key);
  bytes += size;
  while (bytes > kMaxBytes && order.size() > 1) {
    const auto& old = cache.at(order.front());
    bytes -= held(*old);
    cache.erase(order.front());
    order.pop_front();
  }
  return tables;
}

RemapTables BuildDistortTables(const TsaiCamera& camera) {
  return BuildTables(camera, [&camera](const Eigen::Vector2d& distorted, Eigen::Vector2d* source) {
    *source = camera.UndistortPixel(distorted);
    return true;
  });
}

cv::Mat Remap(const cv::Mat& image, const RemapTables& tables) {
  core::Require(!image.empty(), "Remap", "image is empty");
  core::Require(image.size() == tables.map_x.size(), "Remap",
                "image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                    ", the remap tables are " + std::to_string(tables.map_x.cols) + "x" +
                    std::to_string(tables.map_x.rows));
  cv::Mat out;
  try {
    cv::remap(image, out, tables.map_x, tables.map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
              cv::Scalar::all(0));
  } catch (const cv::Exception& e) {
    throw core::InputError("Remap", "OpenCV cannot resample an image of type " +
                                        cv::typeToString(image.type()) + ": " + e.what());
  }
  return out;
}

cv::Mat UndistortImage(const TsaiCamera& camera, const cv::Mat& distorted) {
  RequireImageSize(camera, distorted, "distorted");
  return Remap(distorted, BuildUndistortTables(camera));
}

cv::Mat DistortImage(const TsaiCamera& camera, const cv::Mat& ideal) {
  RequireImageSize(camera, ideal, "ideal");
  return Remap(ideal, BuildDistortTables(camera));
}

}  // namespace dome::geometry
