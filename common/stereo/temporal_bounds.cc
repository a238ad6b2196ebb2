#include "stereo/temporal_bounds.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace dome::stereo {

void TemporalBoundsOptions::Check() const {
  core::Require(tile_px >= 4 && tile_px <= 256, "temporal.tile_px",
                "expected 4..256 pixels, got " + std::to_string(tile_px));
  core::Require(std::isfinite(margin_levels) && margin_levels >= 1.0, "temporal.margin_levels",
                "expected at least 1 level, got " + std::to_string(margin_levels));
  core::Require(std::isfinite(change_factor) && change_factor >= 1.0, "temporal.change_factor",
                "expected at least 1 (times the image's median difference), got " +
                    std::to_string(change_factor));
  core::Require(std::isfinite(change_floor_grey) && change_floor_grey >= 0.0,
                "temporal.change_floor_grey",
                "expected a non-negative grey, got " + std::to_string(change_floor_grey));
  core::Require(outlier_fraction >= 0.0 && outlier_fraction < 0.5, "temporal.outlier_fraction",
                "expected a fraction in [0, 0.5), got " + std::to_string(outlier_fraction));
  core::Require(min_depth_fraction > 0.0 && min_depth_fraction <= 1.0,
                "temporal.min_depth_fraction",
                "expected a fraction in (0, 1], got " + std::to_string(min_depth_fraction));
}

namespace {

struct Tile {
  int depths = 0;  // pixels with a previous depth (any window)
  int pixels = 0;
  std::vector<float> found;                 // the previous depths, every window's
  float near_mm = INFINITY, far_mm = 0.0f;  // their robust least and greatest
};

}  // namespace

cv::Mat ChangedTiles(const cv::Mat& grey_before, const cv::Mat& grey_now, int tile_px,
                     double change_factor, double change_floor_grey, const std::string& where,
                     double* threshold_grey) {
  const cv::Size size = grey_now.size();
  core::Require(grey_now.type() == CV_32FC1 && grey_before.type() == CV_32FC1 &&
                    grey_before.size() == size && !size.empty(),
                where,
                "the greys of the two instants must be one float per pixel of one size, got " +
                    std::to_string(grey_before.cols) + "x" + std::to_string(grey_before.rows) +
                    " and " + std::to_string(size.width) + "x" + std::to_string(size.height));
  core::Require(tile_px >= 1, where, "tiles of at least 1 px, got " + std::to_string(tile_px));
  const int t = tile_px;
  const int tx_n = (size.width + t - 1) / t, ty_n = (size.height + t - 1) / t;
  std::vector<double> diff(size_t(tx_n) * size_t(ty_n), 0.0);
  std::vector<int> count(diff.size(), 0);
  for (int y = 0; y < size.height; ++y) {
    const float* a = grey_before.ptr<float>(y);
    const float* b = grey_now.ptr<float>(y);
    const size_t row = size_t(y / t) * size_t(tx_n);
    for (int x = 0; x < size.width; ++x) {
      if (std::isfinite(a[x]) && std::isfinite(b[x])) {
        diff[row + size_t(x / t)] += std::abs(double(b[x]) - double(a[x]));
        ++count[row + size_t(x / t)];
      }
    }
  }
  std::vector<double> diffs;
  for (size_t i = 0; i < diff.size(); ++i) {
    if (count[i] > 0) diffs.push_back(diff[i] /= count[i]);
  }
  double median = 0.0;
  if (!diffs.empty()) {
    std::nth_element(diffs.begin(), diffs.begin() + diffs.size() / 2, diffs.end());
    median = diffs[diffs.size() / 2];
  }
  const double threshold = change_factor * median + change_floor_grey;
  cv::Mat changed(ty_n, tx_n, CV_8UC1);
  for (size_t i = 0; i < diff.size(); ++i)
    changed.data[i] = count[i] == 0 || diff[i] > threshold;
  if (threshold_grey) *threshold_grey = threshold;
  return changed;
}

SearchBounds TemporalBounds(const std::vector<RangeImage>& previous, const cv::Mat& grey_before,
                            const cv::Mat& grey_now, double z_min_mm, double z_max_mm,
                            int num_levels, const TemporalBoundsOptions& options,
                            const std::string& where, TemporalBoundsStats* stats) {
  options.Check();
  core::Require(z_min_mm > 0 && z_min_mm < z_max_mm && num_levels >= 2, where,
                "temporal bounds need 0 < z_min < z_max and at least 2 levels");
  TemporalBoundsStats st;
  const cv::Mat changed =
      ChangedTiles(grey_before, grey_now, options.tile_px, options.change_factor,
                   options.change_floor_grey, where, &st.threshold_grey);
  const cv::Size size = grey_now.size();
  for (const RangeImage& r : previous) {
    core::Require(r.depth_mm.type() == CV_32FC1 && r.depth_mm.size() == size, where,
                  "the previous instant's range image (window " + std::to_string(r.window_px) +
                      " px) is " + std::to_string(r.depth_mm.cols) + "x" +
                      std::to_string(r.depth_mm.rows) + ", not the camera's " +
                      std::to_string(size.width) + "x" + std::to_string(size.height) +
                      " floats");
  }
  const int t = options.tile_px;
  const int tx_n = changed.cols, ty_n = changed.rows;
  std::vector<Tile> tiles(size_t(tx_n) * size_t(ty_n));
  for (int y = 0; y < size.height; ++y) {
    Tile* row = &tiles[size_t(y / t) * size_t(tx_n)];
    for (int x = 0; x < size.width; ++x) {
      Tile& tile = row[x / t];
      ++tile.pixels;
      // Every window's depth; the pixel counted once when any window has one.
      bool any = false;
      for (const RangeImage& r : previous) {
        const float d = r.depth_mm.ptr<float>(y)[x];
        if (!(d > 0)) continue;
        tile.found.push_back(d);
        any = true;
      }
      tile.depths += any;
    }
  }
  // A tile's range leaves out its outlying depths (wrong matches in the air, a few in
  // a hundred): without it one of them in a tile widens the search to the whole range.
  for (Tile& tile : tiles) {
    if (tile.found.empty()) continue;
    auto& f = tile.found;
    const size_t lo = size_t(options.outlier_fraction * double(f.size()));
    const size_t hi = f.size() - 1 - lo;
    std::nth_element(f.begin(), f.begin() + lo, f.end());
    tile.near_mm = f[lo];
    std::nth_element(f.begin(), f.begin() + hi, f.end());
    tile.far_mm = f[hi];
    f = {};
  }
  st.tiles = int(tiles.size());
  // A still tile with enough previous depths is known.
  std::vector<char> known(tiles.size(), 0);
  for (size_t i = 0; i < tiles.size(); ++i) {
    const Tile& tile = tiles[i];
    const bool is_changed = changed.data[i] != 0;
    const bool enough = tile.depths >= options.min_depth_fraction * tile.pixels;
    known[i] = !is_changed && enough;
    st.bounded += known[i];
    st.changed += is_changed;
    st.unknown += !is_changed && !enough;
  }
  // The margin in inverse depth: margin_levels steps of the search.
  const double inv_near = 1.0 / z_min_mm, inv_far = 1.0 / z_max_mm;
  const double margin = options.margin_levels * (inv_near - inv_far) / (num_levels - 1);
  SearchBounds bounds{cv::Mat(size, CV_32FC2)};
  for (int j = 0; j < ty_n; ++j) {
    for (int i = 0; i < tx_n; ++i) {
      float lo = float(z_min_mm), hi = float(z_max_mm);
      if (known[size_t(j) * tx_n + i]) {
        float near_mm = INFINITY, far_mm = 0.0f;
        for (int v = std::max(j - 1, 0); v <= std::min(j + 1, ty_n - 1); ++v) {
          for (int u = std::max(i - 1, 0); u <= std::min(i + 1, tx_n - 1); ++u) {
            const Tile& n = tiles[size_t(v) * tx_n + u];
            if (n.depths == 0) continue;
            near_mm = std::min(near_mm, n.near_mm);
            far_mm = std::max(far_mm, n.far_mm);
          }
        }
        const double inv_lo = std::min(inv_near, 1.0 / near_mm + margin);
        const double inv_hi = std::max(inv_far, 1.0 / far_mm - margin);
        lo = float(std::max(z_min_mm, 1.0 / inv_lo));
        hi = float(std::min(z_max_mm, 1.0 / inv_hi));
      }
      const cv::Rect rect = cv::Rect(i * t, j * t, t, t) & cv::Rect(cv::Point(), size);
      bounds.near_far_mm(rect).setTo(cv::Scalar(lo, hi));
    }
  }
  if (stats) *stats = st;
  return bounds;
}

SearchBounds IntersectBounds(const SearchBounds& outer, const SearchBounds& inner) {
  DOME_CHECK(outer.near_far_mm.size() == inner.near_far_mm.size() &&
                 outer.near_far_mm.type() == CV_32FC2 && inner.near_far_mm.type() == CV_32FC2,
             "bounds of one grid");
  SearchBounds out{outer.near_far_mm.clone()};
  for (int y = 0; y < out.near_far_mm.rows; ++y) {
    cv::Vec2f* o = out.near_far_mm.ptr<cv::Vec2f>(y);
    const cv::Vec2f* n = inner.near_far_mm.ptr<cv::Vec2f>(y);
    for (int x = 0; x < out.near_far_mm.cols; ++x) {
      if (!(o[x][0] < o[x][1])) continue;
      const float lo = std::max(o[x][0], n[x][0]), hi = std::min(o[x][1], n[x][1]);
      if (lo < hi) o[x] = cv::Vec2f(lo, hi);
    }
  }
  return out;
}

}  // namespace dome::stereo
