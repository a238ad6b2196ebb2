#include "stereo/search_bounds.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace dome::stereo {

void SearchBounds::Check(cv::Size size, const std::string& where) const {
  core::Require(near_far_mm.type() == CV_32FC2 && near_far_mm.size() == size, where,
                "search bounds must be two floats (near, far mm) per pixel of " +
                    std::to_string(size.width) + "x" + std::to_string(size.height) + ", got " +
                    std::to_string(near_far_mm.cols) + "x" + std::to_string(near_far_mm.rows) +
                    " of type code " + std::to_string(near_far_mm.type()));
  for (int y = 0; y < near_far_mm.rows; ++y) {
    const cv::Vec2f* b = near_far_mm.ptr<cv::Vec2f>(y);
    for (int x = 0; x < near_far_mm.cols; ++x) {
      // The message is built only for a bad pixel: this runs on every pixel of a job.
      if (std::isfinite(b[x][0]) && std::isfinite(b[x][1]) && b[x][0] >= 0 && b[x][1] >= 0)
        continue;
      throw core::InputError(where, "search bounds of pixel (" + std::to_string(x) + ", " +
                                        std::to_string(y) +
                                        ") are not finite non-negative depths");
    }
  }
}

bool SearchBounds::Range(const cv::Rect& rect, double* near_mm, double* far_mm) const {
  float lo = INFINITY, hi = 0;
  for (int y = rect.y; y < rect.br().y; ++y) {
    const cv::Vec2f* b = near_far_mm.ptr<cv::Vec2f>(y);
    for (int x = rect.x; x < rect.br().x; ++x) {
      if (!(b[x][0] < b[x][1])) continue;
      lo = std::min(lo, b[x][0]);
      hi = std::max(hi, b[x][1]);
    }
  }
  *near_mm = lo;
  *far_mm = hi;
  return lo < hi;
}

cv::Rect SearchBounds::SearchedRect(const cv::Rect& rect) const {
  int x0 = rect.br().x, y0 = rect.br().y, x1 = rect.x - 1, y1 = rect.y - 1;
  for (int y = rect.y; y < rect.br().y; ++y) {
    const cv::Vec2f* b = near_far_mm.ptr<cv::Vec2f>(y);
    for (int x = rect.x; x < rect.br().x; ++x) {
      if (!(b[x][0] < b[x][1])) continue;
      x0 = std::min(x0, x);
      x1 = std::max(x1, x);
      y0 = std::min(y0, y);
      y1 = std::max(y1, y);
    }
  }
  if (x1 < x0) return {};
  return cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
}

int64_t SearchBounds::Apply(cv::Mat* depth_mm, cv::Mat* reliability) const {
  int64_t cleared = 0;
  for (int y = 0; y < depth_mm->rows; ++y) {
    const cv::Vec2f* b = near_far_mm.ptr<cv::Vec2f>(y);
    float* d = depth_mm->ptr<float>(y);
    float* r = reliability->ptr<float>(y);
    for (int x = 0; x < depth_mm->cols; ++x) {
      if (d[x] > 0 && !(b[x][0] < b[x][1] && d[x] >= b[x][0] && d[x] <= b[x][1])) {
        d[x] = 0;
        r[x] = 0;
        ++cleared;
      }
    }
  }
  return cleared;
}

}  // namespace dome::stereo
