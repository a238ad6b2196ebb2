#include "stereo/speckle.h"

#include <cmath>
#include <string>
#include <vector>

#include "core/error.h"

namespace dome::stereo {

void SpeckleOptions::Check() const {
  core::Require(min_area_px >= 0, "speckle_area_px",
                "must be >= 0 (0 = keep every piece), got " + std::to_string(min_area_px));
  core::Require(min_area_px == 0 || (std::isfinite(max_step_mm) && max_step_mm > 0.0),
                "speckle_step_mm",
                "must be positive when speckle_area_px is set, got " +
                    std::to_string(max_step_mm));
}

int64_t RemoveSpeckles(const SpeckleOptions& options, cv::Mat* depth_mm, cv::Mat* reliability) {
  options.Check();
  DOME_CHECK(depth_mm && depth_mm->type() == CV_32FC1 && depth_mm->isContinuous(),
             "a speckle filter's depth map is continuous CV_32FC1");
  DOME_CHECK(!reliability || reliability->empty() ||
                 (reliability->type() == CV_32FC1 && reliability->size() == depth_mm->size() &&
                  reliability->isContinuous()),
             "a speckle filter's reliability map matches its depth map");
  if (options.min_area_px <= 1) return 0;
  const int w = depth_mm->cols, h = depth_mm->rows;
  float* d = depth_mm->ptr<float>();
  const float step = static_cast<float>(options.max_step_mm);
  // Flood fill of each unlabelled valid pixel; the pixels of a piece are kept in
  // `piece` so that a small one can be cleared without a second pass.
  std::vector<uint8_t> seen(size_t(w) * h, 0);
  std::vector<int32_t> piece;
  int64_t removed = 0;
  for (int32_t start = 0; start < w * h; ++start) {
    if (seen[size_t(start)] || !(d[start] > 0.0f)) continue;
    piece.clear();
    piece.push_back(start);
    seen[size_t(start)] = 1;
    for (size_t next = 0; next < piece.size(); ++next) {
      const int32_t i = piece[next];
      const int x = i % w, y = i / w;
      const float di = d[i];
      auto visit = [&](int32_t j) {
        if (!seen[size_t(j)] && d[j] > 0.0f && std::abs(d[j] - di) <= step) {
          seen[size_t(j)] = 1;
          piece.push_back(j);
        }
      };
      if (x > 0) visit(i - 1);
      if (x + 1 < w) visit(i + 1);
      if (y > 0) visit(i - w);
      if (y + 1 < h) visit(i + w);
    }
    if (piece.size() >= size_t(options.min_area_px)) continue;
    removed += int64_t(piece.size());
    for (int32_t i : piece) {
      d[i] = 0.0f;
      if (reliability && !reliability->empty()) reliability->ptr<float>()[i] = 0.0f;
    }
  }
  return removed;
}

}  // namespace dome::stereo
