// Depth previews (io/depth_tiff.h): a picture of a depth map to look at, made for every
// stereo job's map, so its per-pixel loop is written to vectorize (this file is built
// at -O3 without trapping math, io/CMakeLists.txt).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
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

cv::Mat DepthPreview(const cv::Mat& depth_mm, const DepthPreviewOptions& options) {
  options.Check();
  CheckDepthMap(depth_mm, "depth preview input");
  double near_mm = options.near_mm, far_mm = options.far_mm;
  if (near_mm <= 0.0 && far_mm <= 0.0) {
    std::vector<float> valid;
    for (int y = 0; y < depth_mm.rows; ++y) {
      const float* row = depth_mm.ptr<float>(y);
      for (int x = 0; x < depth_mm.cols; ++x) {
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
  // The colour map's 256 colours (BGR), looked up per pixel below: applyColorMap and a
  // masked setTo over the whole picture were two more passes than the lookup.
  cv::Mat ramp(1, 256, CV_8UC1);
  for (int i = 0; i < 256; ++i) ramp.at<uint8_t>(0, i) = uint8_t(i);
  cv::Mat colours;
  cv::applyColorMap(ramp, colours, options.colormap);
  // Each colour as 4 bytes (B, G, R, 0): a pixel is one 4-byte store whose fourth byte
  // the next pixel's store overwrites.
  uint32_t lut[256];
  for (int i = 0; i < 256; ++i) {
    const uint8_t* c = colours.ptr<uint8_t>(0) + 3 * i;
    lut[i] = uint32_t(c[0]) | uint32_t(c[1]) << 8 | uint32_t(c[2]) << 16;
  }
  const double span = far_mm - near_mm;
  cv::Mat preview(depth_mm.size(), CV_8UC3);
  const int cols = depth_mm.cols;  // a local: the byte stores below may alias the Mat
  std::vector<uint8_t> level(static_cast<size_t>(cols));
  uint8_t* lv = level.data();
  for (int y = 0; y < depth_mm.rows; ++y) {
    const float* in = depth_mm.ptr<float>(y);
    if (span > 0.0) {
      // Near -> 255, rounded half up: v - trunc(v) is exact for v >= 0, and the loop has
      // no library call or branch, so it runs four or eight pixels a vector.
      for (int x = 0; x < cols; ++x) {
        const double t = (far_mm - in[x]) / span;
        const double v = std::min(std::max(t, 0.0), 1.0) * 255.0;
        const int whole = static_cast<int>(v);
        lv[x] = static_cast<uint8_t>(whole + int(v - whole >= 0.5));
      }
    } else {
      std::fill(level.begin(), level.end(), uint8_t{255});
    }
    uint8_t* out = preview.ptr<uint8_t>(y);
    for (int x = 0; x + 1 < cols; ++x) {
      const uint32_t c = in[x] > 0.0f ? lut[lv[x]] : 0;  // no depth: black
      std::memcpy(out + 3 * x, &c, 4);
    }
    if (cols > 0) {  // the last pixel: three bytes
      const uint32_t c = in[cols - 1] > 0.0f ? lut[lv[cols - 1]] : 0;
      std::memcpy(out + 3 * (cols - 1), &c, 3);
    }
  }
  return preview;
}

void WriteDepthPreviewPng(const std::filesystem::path& path, const cv::Mat& depth_mm,
                          const DepthPreviewOptions& options) {
  CheckDepthMap(depth_mm, path.string());
  WriteImage(path, DepthPreview(depth_mm, options), PngEncoding::kFast);
}

std::string EncodeDepthPreviewPng(const cv::Mat& depth_mm, const std::string& where,
                                  const DepthPreviewOptions& options) {
  CheckDepthMap(depth_mm, where);
  return EncodePng(DepthPreview(depth_mm, options), PngEncoding::kFast);  // a picture to look at
}

}  // namespace dome::io
