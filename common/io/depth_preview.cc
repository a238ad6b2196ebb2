// Depth previews (io/depth_tiff.h): a picture of a depth map to look at, made for every
// stereo job's map, so its per-pixel loop is written to vectorize (this file is built
// at -O3 without trapping math, io/CMakeLists.txt).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/error.h"
#include "io/depth_tiff.h"
#include "io/image_io.h"

namespace dome::io {

void DepthPreviewOptions::Check() const {
  core::Require(std::isfinite(near_mm) && std::isfinite(far_mm), "near_mm/far_mm",
                "must be finite");
  const bool automatic = near_mm <= 0.0 && far_mm <= 0.0;
  core::Require(automatic || (near_mm > 0.0 && far_mm > near_mm), "near_mm/far_mm",
                "both <= 0 (automatic) or 0 < near_mm < far_mm");
  core::Require(colormap >= 0 && colormap <= cv::COLORMAP_DEEPGREEN, "colormap",
                "must be an OpenCV ColormapTypes value");
}

cv::Mat DepthPreviewIndices(const cv::Mat& depth_mm, const DepthPreviewOptions& options,
                            std::vector<cv::Vec3b>* palette) {
  options.Check();
  CheckDepthMap(depth_mm, "depth preview input");
  double near_mm = options.near_mm, far_mm = options.far_mm;
  if (near_mm <= 0.0 && far_mm <= 0.0) {
    // The percentiles of the valid depths on a grid of about 2^16 pixels (every pixel of
    // a map that small): the picture's ends, not measurements.
    const int step = std::max(1, int(std::sqrt(double(depth_mm.total()) / 65536.0)));
    std::vector<float> valid;
    for (int y = 0; y < depth_mm.rows; y += step) {
      const float* row = depth_mm.ptr<float>(y);
      for (int x = 0; x < depth_mm.cols; x += step) {
        if (row[x] > 0.0f) {
          valid.push_back(row[x]);
        }
      }
    }
    if (!valid.empty()) {
      auto at = [&](double q) {
        auto it = valid.begin() + static_cast<int64_t>(q * (valid.size() - 1));
        std::nth_element(valid.begin(), it, valid.end());
        return static_cast<double>(*it);
      };
      near_mm = at(0.01);
      far_mm = at(0.99);
    }
  }
  // The palette: black, then kDepthPreviewLevels colours of the colour map from its far
  // end (0) to its near end (255), evenly over it.
  cv::Mat ramp(1, kDepthPreviewLevels, CV_8UC1);
  for (int i = 0; i < kDepthPreviewLevels; ++i)
    ramp.at<uint8_t>(0, i) = uint8_t(std::lround(i * 255.0 / (kDepthPreviewLevels - 1)));
  cv::Mat colours;
  cv::applyColorMap(ramp, colours, options.colormap);
  palette->assign(1, cv::Vec3b(0, 0, 0));
  for (int i = 0; i < kDepthPreviewLevels; ++i) palette->push_back(colours.at<cv::Vec3b>(0, i));
  const double span = far_mm - near_mm;
  constexpr double kTop = kDepthPreviewLevels - 1;
  cv::Mat indices(depth_mm.size(), CV_8UC1);
  for (int y = 0; y < depth_mm.rows; ++y) {
    const float* in = depth_mm.ptr<float>(y);
    uint8_t* out = indices.ptr<uint8_t>(y);
    // Near -> the top level, rounded half up: v - trunc(v) is exact for v >= 0, and the
    // loop has no library call or branch, so it runs four or eight pixels a vector.
    for (int x = 0; x < depth_mm.cols; ++x) {
      const double t = span > 0.0 ? (far_mm - in[x]) / span : 1.0;
      const double v = std::min(std::max(t, 0.0), 1.0) * kTop;
      const int whole = static_cast<int>(v);
      const int level = 1 + whole + int(v - whole >= 0.5);
      out[x] = static_cast<uint8_t>(in[x] > 0.0f ? level : 0);  // no depth: black
    }
  }
  return indices;
}

cv::Mat DepthPreview(const cv::Mat& depth_mm, const DepthPreviewOptions& options) {
  std::vector<cv::Vec3b> palette;
  const cv::Mat indices = DepthPreviewIndices(depth_mm, options, &palette);
  cv::Mat preview(indices.size(), CV_8UC3);
  for (int y = 0; y < indices.rows; ++y) {
    const uint8_t* in = indices.ptr<uint8_t>(y);
    cv::Vec3b* out = preview.ptr<cv::Vec3b>(y);
    for (int x = 0; x < indices.cols; ++x) out[x] = palette[in[x]];
  }
  return preview;
}

void WriteDepthPreviewPng(const std::filesystem::path& path, const cv::Mat& depth_mm,
                          const DepthPreviewOptions& options) {
  CheckDepthMap(depth_mm, path.string());
  std::vector<cv::Vec3b> palette;
  const cv::Mat indices = DepthPreviewIndices(depth_mm, options, &palette);
  WritePaletteImage(path, indices, palette, PngEncoding::kFast);
}

std::string EncodeDepthPreviewPng(const cv::Mat& depth_mm, const std::string& where,
                                  const DepthPreviewOptions& options) {
  CheckDepthMap(depth_mm, where);
  // A palette PNG: a third of the bytes to compress that the BGR picture has, for the
  // same picture (a Robovision camera's preview: 18 ms and 275 kB as BGR).
  std::vector<cv::Vec3b> palette;
  const cv::Mat indices = DepthPreviewIndices(depth_mm, options, &palette);
  return EncodePalettePng(indices, palette, PngEncoding::kFast);  // a picture to look at
}

}  // namespace dome::io
