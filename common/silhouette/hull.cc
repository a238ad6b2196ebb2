#include "silhouette/hull.h"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/parallel_for.h"
#include "geometry/undistort.h"

namespace dome::silhouette {

using core::Require;

namespace {

// The pixel column (or row) of coordinate v in an image `size` pixels wide: std::lround's
// value (half away from zero) when that is in 0..size-1, else false. Branch-free past
// the range test (v - trunc(v) is exact; the tests of the hull's loops are this): a
// branch on the fraction, or the library call, cost more than the test around it.
inline bool PixelOf(double v, int size, int* px) {
  if (!(v > -0.5 && v < size - 0.5)) return false;  // lround(-0.5) is -1, lround(size - 0.5) size
  const int t = int(v);  // truncation: v's floor for v >= 0, 0 for v in (-0.5, 0)
  *px = t + int(v - t >= 0.5);
  return true;
}

}  // namespace

void HullOptions::Check() const {
  Require(std::isfinite(margin_fraction) && margin_fraction >= 0 && margin_fraction < 0.1,
          "HullOptions: margin_fraction",
          "expected a fraction of the image diagonal in [0, 0.1), got " +
              std::to_string(margin_fraction));
  Require(carve_votes >= 1, "HullOptions: carve_votes",
          "expected at least 1, got " + std::to_string(carve_votes));
  Require(min_views >= 2, "HullOptions: min_views",
          "expected at least 2 cameras, got " + std::to_string(min_views));
  Require(ray_block_px >= 1 && ray_block_px <= 64, "HullOptions: ray_block_px",
          "expected 1..64 pixels, got " + std::to_string(ray_block_px));
  Require(ray_leaf_px >= 1 && ray_leaf_px <= 64, "HullOptions: ray_leaf_px",
          "expected 1..64 pixels, got " + std::to_string(ray_leaf_px));
}

int HullOptions::MarginPx(cv::Size size) const {
  return std::max(1, int(std::lround(margin_fraction * std::hypot(size.width, size.height))));
}

VisualHull::VisualHull(const std::vector<geometry::TsaiCamera>& cameras,
                       const std::vector<cv::Mat>& masks, const HullOptions& options)
    : options_(options) {
  options_.Check();
  DOME_CHECK(cameras.size() == masks.size(), "VisualHull: one mask per camera");
  views_.resize(cameras.size());
  core::ParallelFor(0, int64_t(cameras.size()), options_.num_threads, [&](int64_t c0, int64_t c1) {
    for (int64_t c = c0; c < c1; ++c) {
      const geometry::TsaiCamera& cam = cameras[c];
      const cv::Mat& mask = masks[c];
      Require(mask.type() == CV_8UC1 && mask.cols == cam.width_px && mask.rows == cam.height_px,
              "mask of camera '" + cam.id + "'",
              "expected 8-bit gray of " + std::to_string(cam.width_px) + "x" +
                  std::to_string(cam.height_px) + ", got " + std::to_string(mask.cols) + "x" +
                  std::to_string(mask.rows) + " of type code " + std::to_string(mask.type()));
      View& v = views_[c];
      v.K = cam.K();
      v.R = cam.rotation;
      v.t = cam.translation_mm;
      v.P.leftCols<3>() = v.K * v.R;
      v.P.col(3) = v.K * v.t;
      v.f_px = 0.5 * (v.K(0, 0) + v.K(1, 1));
      v.width = cam.width_px;
      v.height = cam.height_px;
      cv::Mat fg = mask != 0;
      if (cam.HasDistortion()) {
        // Bilinear resampling of 0 / 255: a pixel at least half foreground stays so.
        // The tables come from the process-wide cache: a worker builds a hull per job.
        const auto tables = geometry::SharedUndistortTables(cam);
        fg = geometry::Remap(fg, *tables) >= 128;
        v.seen = tables->covered > 0;
      } else {
        v.seen = cv::Mat(mask.size(), CV_8UC1, cv::Scalar(255));
      }
      const int r = options_.MarginPx(mask.size());
      cv::dilate(fg, fg, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1)));
      v.fg = fg;
      if (options_.ray_block_px > 1) {
        // Distance to the nearest pixel that is foreground or without data (the zeros),
        // then to the first pixel outside the image on each side.
        cv::Mat clear;
        cv::distanceTransform(~fg & v.seen, clear, cv::DIST_L2, cv::DIST_MASK_PRECISE);
        for (int y = 0; y < clear.rows; ++y) {
          float* d = clear.ptr<float>(y);
          const int dy = std::min(y + 1, clear.rows - y);
          for (int x = 0; x < clear.cols; ++x)
            d[x] = std::min(d[x], float(std::min({x + 1, clear.cols - x, dy})));
        }
        v.clear_px = clear;
      }
      if (!options_.distances) continue;
      // Distance to the nearest foreground pixel outside, to the nearest background
      // pixel inside (distanceTransform measures to the nearest zero).
      cv::Mat out_px, in_px;
      cv::distanceTransform(~fg, out_px, cv::DIST_L2, cv::DIST_MASK_PRECISE);
      cv::distanceTransform(fg, in_px, cv::DIST_L2, cv::DIST_MASK_PRECISE);
      v.signed_px = out_px - in_px;
      const int tw = (v.width + kTilePx - 1) / kTilePx, th = (v.height + kTilePx - 1) / kTilePx;
      v.tile_min_px.create(th, tw, CV_32FC1);
      v.tile_min_px.setTo(std::numeric_limits<float>::infinity());
      for (int y = 0; y < v.height; ++y) {
        const float* d = v.signed_px.ptr<float>(y);
        const uint8_t* seen = v.seen.ptr<uint8_t>(y);
        float* t = v.tile_min_px.ptr<float>(y / kTilePx);
        for (int x = 0; x < v.width; ++x) {
          const float value = seen[x] ? d[x] : -std::numeric_limits<float>::infinity();
          float& m = t[x / kTilePx];
          m = std::min(m, value);
        }
      }
    }
  });
}

bool VisualHull::CarvedBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                           double outside_mm) const {
  DOME_CHECK(options_.distances && outside_mm > 0, "VisualHull::CarvedBox: distances, a distance");
  int carved = 0;
  for (const View& v : views_) {
    // The box's image lies in the hull of its corners' images when every corner is in
    // front of the camera (a perspective map keeps segments segments); z is affine.
    double umin = INFINITY, umax = -INFINITY, vmin = INFINITY, vmax = -INFINITY, zmin = INFINITY;
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3d p(c & 1 ? hi.x() : lo.x(), c & 2 ? hi.y() : lo.y(),
                              c & 4 ? hi.z() : lo.z());
      const Eigen::Vector3d h = v.P.leftCols<3>() * p + v.P.col(3);
      zmin = std::min(zmin, h.z());
      if (!(h.z() > 0)) break;
      umin = std::min(umin, h.x() / h.z()), umax = std::max(umax, h.x() / h.z());
      vmin = std::min(vmin, h.y() / h.z()), vmax = std::max(vmax, h.y() / h.z());
    }
    if (!(zmin > 0)) continue;
    // Every point's pixel (PixelOf rounds), with a pixel to spare for the rounding of
    // the points' own projections; the image's border half a pixel further in.
    if (!(umin > 0.0 && vmin > 0.0 && umax < v.width - 1.0 && vmax < v.height - 1.0)) continue;
    const int x0 = std::max(0, int(umin) - 1), x1 = std::min(v.width - 1, int(umax) + 2);
    const int y0 = std::max(0, int(vmin) - 1), y1 = std::min(v.height - 1, int(vmax) + 2);
    // Sample's test is d_px (h.z / f) >= outside_mm with h.z >= zmin; a relative margin
    // far above the rounding of either side.
    const float need_px = float(outside_mm * v.f_px / zmin * (1 + 1e-6));
    bool all = true;
    for (int ty = y0 / kTilePx; all && ty <= y1 / kTilePx; ++ty) {
      const float* t = v.tile_min_px.ptr<float>(ty);
      for (int tx = x0 / kTilePx; tx <= x1 / kTilePx; ++tx) {
        if (!(t[tx] >= need_px)) {
          all = false;
          break;
        }
      }
    }
    if (all && ++carved >= options_.carve_votes) return true;
  }
  return false;
}

cv::Mat VisualHull::IdealMask(int index) const {
  return views_.at(size_t(index)).fg.clone();
}

HullSample VisualHull::Sample(const Eigen::Vector3d& world_mm, double radius_mm, int skip,
                              double enough_outside_mm) const {
  DOME_CHECK(radius_mm == 0 || options_.distances, "VisualHull::Sample: a radius needs distances");
  HullSample s;
  double inside = std::numeric_limits<double>::infinity();
  for (int c = 0; c < int(views_.size()); ++c) {
    if (c == skip) continue;
    const View& v = views_[c];
    const Eigen::Vector3d h = v.P.leftCols<3>() * world_mm + v.P.col(3);
    if (!(h.z() > 0)) continue;
    int x, y;
    if (!PixelOf(h.x() / h.z(), v.width, &x) || !PixelOf(h.y() / h.z(), v.height, &y) ||
        !v.seen.at<uint8_t>(y, x))
      continue;
    ++s.seen;
    const double mm_per_px = h.z() / v.f_px;
    const double d_px = v.signed_px.empty() ? (v.fg.at<uint8_t>(y, x) ? 0.0 : 1.0)
                                            : v.signed_px.at<float>(y, x) - radius_mm / mm_per_px;
    if (d_px > 0) {
      ++s.background;
      s.outside_mm = std::max(s.outside_mm, d_px * mm_per_px);
      if (s.background >= options_.carve_votes && s.outside_mm >= enough_outside_mm) break;
    } else {
      inside = std::min(inside, -d_px * mm_per_px);
    }
  }
  s.inside_mm = std::isfinite(inside) ? inside : 0.0;
  s.inside = s.seen - s.background >= options_.min_views && s.background < options_.carve_votes;
  return s;
}

bool VisualHull::BoundingBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int cells,
                             Eigen::Vector3d* hull_lo, Eigen::Vector3d* hull_hi,
                             int min_views) const {
  DOME_CHECK(cells >= 1 && (hi - lo).minCoeff() > 0, "VisualHull::BoundingBox: a box and cells");
  DOME_CHECK(options_.distances, "VisualHull::BoundingBox: needs distances");
  const double cell = (hi - lo).maxCoeff() / cells;
  Eigen::Vector3i n;
  for (int a = 0; a < 3; ++a) n[a] = std::max(1, int(std::ceil((hi[a] - lo[a]) / cell)));
  const double radius = 0.5 * std::sqrt(3.0) * cell;
  // Per plane k: the least and greatest cell indices inside (x, y), plus k itself.
  std::vector<Eigen::Vector4i> found(size_t(n.z()), Eigen::Vector4i(n.x(), n.y(), -1, -1));
  core::ParallelFor(0, n.z(), options_.num_threads, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k) {
      Eigen::Vector4i& f = found[size_t(k)];
      // A cell's vote stops once carve_votes cameras carve it (enough_outside_mm 0): the
      // box needs only the verdict, not the distances.
      auto inside = [&](int i, int j) {
        const Eigen::Vector3d p = lo + cell * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5);
        const HullSample s = Sample(p, radius, /*skip=*/-1, /*enough_outside_mm=*/0.0);
        return s.inside && s.seen - s.background >= min_views;
      };
      for (int j = 0; j < n.y(); ++j) {
        // The box needs only each row's first and last cell inside: the row is scanned
        // from both ends, and the cells between are not tested.
        int first = 0;
        while (first < n.x() && !inside(first, j)) ++first;
        if (first == n.x()) continue;
        int last = n.x() - 1;
        while (last > first && !inside(last, j)) --last;
        f = Eigen::Vector4i(std::min(f[0], first), std::min(f[1], j), std::max(f[2], last),
                            std::max(f[3], j));
      }
    }
  });
  Eigen::Vector3i a(n.x(), n.y(), n.z()), b(-1, -1, -1);
  for (int k = 0; k < n.z(); ++k) {
    const Eigen::Vector4i& f = found[size_t(k)];
    if (f[2] < 0) continue;
    a = Eigen::Vector3i(std::min(a.x(), f[0]), std::min(a.y(), f[1]), std::min(a.z(), k));
    b = Eigen::Vector3i(std::max(b.x(), f[2]), std::max(b.y(), f[3]), std::max(b.z(), k));
  }
  if (b.z() < 0) return false;
  *hull_lo = lo + cell * a.cast<double>();
  *hull_hi = (lo + cell * (b + Eigen::Vector3i::Ones()).cast<double>()).cwiseMin(hi);
  return true;
}

cv::Mat VisualHull::RayBounds(int index, double z_min_mm, double z_max_mm, int num_samples) const {
  DOME_CHECK(index >= 0 && index < int(views_.size()) && z_min_mm > 0 && z_max_mm > z_min_mm,
             "VisualHull::RayBounds: a camera and a depth range");
  const View& ref = views_[size_t(index)];
  // Per other camera, the ray of reference pixel x at inverse depth w projects to
  // h ~ A x + w b (A = K_n R K_r^-1, b = K_n (t_n - R t_r), R = R_n R_r^T); h.z has the
  // sign of the point's depth in camera n.
  // With what the block test reads of the camera in one place: its principal point,
  // reciprocal focal lengths, larger focal length (px) and clear_px rows (floats).
  struct Other {
    Eigen::Matrix3d A;
    Eigen::Vector3d b;
    const View* view;
    double cx, cy, inv_fx, inv_fy, f_max;
    int width, height;
    const float* clear;
    size_t clear_step;
  };
  std::vector<Other> others;
  const Eigen::Matrix3d K_inv = ref.K.inverse();
  for (int c = 0; c < int(views_.size()); ++c) {
    if (c == index) continue;
    const View& v = views_[c];
    const Eigen::Matrix3d R = v.R * ref.R.transpose();
    const bool blocks = !v.clear_px.empty();
    others.push_back({v.K * R * K_inv, v.K * (v.t - R * ref.t), &v, v.K(0, 2), v.K(1, 2),
                      1.0 / v.K(0, 0), 1.0 / v.K(1, 1), std::max(v.K(0, 0), v.K(1, 1)),
                      v.width, v.height, blocks ? v.clear_px.ptr<float>(0) : nullptr,
                      blocks ? v.clear_px.step1() : 0});
  }
  const double w_near = 1.0 / z_min_mm, w_far = 1.0 / z_max_mm;
  // Samples: the longest projection of the ray's range into another camera, over a
  // 9x9 grid of reference pixels, in pixels (ends in front of that camera).
  double longest = 1.0;
  for (int gy = 0; gy < 9 && num_samples <= 0; ++gy) {
    for (int gx = 0; gx < 9; ++gx) {
      const Eigen::Vector3d x((ref.width - 1) * gx / 8.0, (ref.height - 1) * gy / 8.0, 1.0);
      for (const Other& o : others) {
        const Eigen::Vector3d p = o.A * x, a = p + w_near * o.b, b = p + w_far * o.b;
        if (!(a.z() > 0 && b.z() > 0)) continue;
        longest = std::max(longest, (a.hnormalized() - b.hnormalized()).norm());
      }
    }
  }
  const int samples = num_samples > 0 ? std::max(2, num_samples)
                                      : std::clamp(int(std::ceil(longest)) + 1, 2, 1 << 14);
  const double dw = (w_near - w_far) / (samples - 1);
  const int votes = options_.carve_votes;
  const int min_views = options_.min_views;
  const int block = options_.ray_block_px;
  const int leaf = block > 1 ? std::min(options_.ray_leaf_px, block) : 1;  // 1: none
  // Reference pixel offsets -> normalised offsets at unit depth (K has no skew).
  const double inv_fx = 1.0 / ref.K(0, 0), inv_fy = 1.0 / ref.K(1, 1);
  cv::Mat bounds(ref.height, ref.width, CV_32FC2, cv::Scalar(0, 0));
  const int block_rows = (ref.height + block - 1) / block;
  core::ParallelFor(0, block_rows, options_.num_threads, [&](int64_t b0, int64_t b1) {
    std::vector<Eigen::Vector3d> p(others.size());
    // The order the cameras are asked in: those that voted background last come first
    // (the next sample along a ray, the next ray, is mostly carved by the same cameras,
    // so an outside sample costs about carve_votes projections). The verdicts do not
    // depend on the order: counts, and a stop only once carve_votes say background.
    std::vector<size_t> order(others.size());
    for (size_t n = 0; n < order.size(); ++n) order[n] = n;
    // Pixel (x, y): its first and last inside sample within [lo, hi] (the samples outside
    // are outside), widened by a step, as depths.
    auto pixel = [&](int x, int y, int lo, int hi) {
      if (!ref.fg.at<uint8_t>(y, x) || !ref.seen.at<uint8_t>(y, x)) return;
      for (size_t n = 0; n < others.size(); ++n)
        p[n] = others[n].A * Eigen::Vector3d(x, double(y), 1.0);
      auto inside = [&](int i) {
        const double w = w_near - i * dw;
        int s = 1, bg = 0;  // the reference sees it in its foreground
        for (size_t m = 0; m < order.size() && bg < votes; ++m) {
          const size_t n = order[m];
          const Eigen::Vector3d h = p[n] + w * others[n].b;
          if (!(h.z() > 0)) continue;
          const View& v = *others[n].view;
          int u, r;
          if (!PixelOf(h.x() / h.z(), v.width, &u) || !PixelOf(h.y() / h.z(), v.height, &r) ||
              !v.seen.at<uint8_t>(r, u))
            continue;
          ++s;
          if (!v.fg.at<uint8_t>(r, u)) std::swap(order[m], order[size_t(bg++)]);
        }
        return s - bg >= min_views && bg < votes;
      };
      int first = lo;
      while (first <= hi && !inside(first)) ++first;
      if (first > hi) return;
      int last = hi;
      while (last > first && !inside(last)) --last;
      const double near_w = w_near - (first - 1) * dw, far_w = w_near - (last + 1) * dw;
      cv::Vec2f& out = bounds.at<cv::Vec2f>(y, x);
      out[0] = float(std::max(z_min_mm, 1.0 / near_w));
      out[1] = float(far_w > 0 ? std::min(z_max_mm, 1.0 / far_w) : z_max_mm);
    };
    // The block [x0, x1) x [y0, y1) whose rays can be inside only at samples [lo, hi]:
    // narrowed by the block test, then halved down to pixels.
    std::function<void(int, int, int, int, int, int)> refine = [&](int x0, int y0, int x1,
                                                                   int y1, int lo, int hi) {
      if (x1 - x0 == 1 && y1 - y0 == 1) return pixel(x0, y0, lo, hi);
      bool any = false;
      for (int y = y0; y < y1 && !any; ++y) {
        const uint8_t* own = ref.fg.ptr<uint8_t>(y);
        const uint8_t* seen = ref.seen.ptr<uint8_t>(y);
        for (int x = x0; x < x1 && !any; ++x) any = own[x] && seen[x];
      }
      if (!any) return;
      // At depth z the block's ray points lie within z * spread mm of its centre ray's.
      const double xc = 0.5 * (x0 + x1 - 1), yc = 0.5 * (y0 + y1 - 1);
      const double spread = std::hypot(0.5 * (x1 - 1 - x0) * inv_fx, 0.5 * (y1 - 1 - y0) * inv_fy);
      for (size_t n = 0; n < others.size(); ++n) p[n] = others[n].A * Eigen::Vector3d(xc, yc, 1.0);
      // True when carve_votes cameras see the whole ball of the block's points at sample
      // i as background: then every pixel's exact test votes it outside.
      auto outside = [&](int i) {
        const double w = w_near - i * dw, z = 1.0 / w;
        const double r_mm = z * spread * (1.0 + 1e-9);
        int bg = 0;
        for (size_t m = 0; m < order.size(); ++m) {
          const size_t n = order[m];
          const Eigen::Vector3d h = p[n] + w * others[n].b;
          const double depth = h.z() * z;  // the centre's depth in camera n, mm
          if (!(depth - r_mm > 0)) continue;
          const Other& o = others[n];
          // The centre's pixel (one reciprocal: a test near the hull asks every camera,
          // so this is the hot path; the test's slack below holds the rounding).
          const double inv = 1.0 / h.z(), u = h.x() * inv, t = h.y() * inv;
          int cu, cv_;
          if (!PixelOf(u, o.width, &cu) || !PixelOf(t, o.height, &cv_)) continue;
          // A point P of the ball, |P - C| <= r, projects within f r (1 + |C_xy| / C_z) /
          // (C_z - r) pixels of C's projection; the roundings to pixels add sqrt(2).
          const double nu = (u - o.cx) * o.inv_fx, nv = (t - o.cy) * o.inv_fy;
          const double rho = std::sqrt(nu * nu + nv * nv);
          const double reach_px =
              o.f_max * r_mm * (1.0 + rho) / (depth - r_mm) + std::sqrt(2.0) + 1e-3;
          if (o.clear[size_t(cv_) * o.clear_step + size_t(cu)] > reach_px) {
            std::swap(order[m], order[size_t(bg)]);
            if (++bg >= votes) return true;
          }
        }
        return false;
      };
      while (lo <= hi && outside(lo)) ++lo;
      if (lo > hi) return;
      while (hi > lo && outside(hi)) --hi;
      if (x1 - x0 <= leaf && y1 - y0 <= leaf) {
        // A leaf: its samples [lo, hi] for each of its pixels in the camera's own mask.
        const double near_w = w_near - (lo - 1) * dw, far_w = w_near - (hi + 1) * dw;
        const cv::Vec2f b(float(std::max(z_min_mm, 1.0 / near_w)),
                          float(far_w > 0 ? std::min(z_max_mm, 1.0 / far_w) : z_max_mm));
        for (int y = y0; y < y1; ++y) {
          for (int x = x0; x < x1; ++x) {
            if (ref.fg.at<uint8_t>(y, x) && ref.seen.at<uint8_t>(y, x))
              bounds.at<cv::Vec2f>(y, x) = b;
          }
        }
        return;
      }
      const int xm = (x0 + x1 + 1) / 2, ym = (y0 + y1 + 1) / 2;
      refine(x0, y0, xm, ym, lo, hi);
      if (xm < x1) refine(xm, y0, x1, ym, lo, hi);
      if (ym < y1) refine(x0, ym, xm, y1, lo, hi);
      if (xm < x1 && ym < y1) refine(xm, ym, x1, y1, lo, hi);
    };
    for (int64_t by = b0; by < b1; ++by) {
      const int y0 = int(by) * block, y1 = std::min(ref.height, y0 + block);
      for (int x0 = 0; x0 < ref.width; x0 += block) {
        const int x1 = std::min(ref.width, x0 + block);
        if (block == 1) {
          pixel(x0, y0, 0, samples - 1);
        } else {
          refine(x0, y0, x1, y1, 0, samples - 1);
        }
      }
    }
  });
  return bounds;
}

}  // namespace dome::silhouette
