#include "stereo/multi_baseline.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/parallel_for.h"
#include "core/timer.h"
#include "geometry/undistort.h"
#include "stereo/cost_kernel.h"

namespace dome::stereo {
namespace {

constexpr int kMaxWindowPx = 31;

// Plane-induced homography pieces: x_n ~ A x_r + w b.
void HomographyPieces(const geometry::TsaiCamera& ref, const geometry::TsaiCamera& nb,
                      Eigen::Matrix3d* a, Eigen::Vector3d* b) {
  const Eigen::Matrix3d r = nb.rotation * ref.rotation.transpose();
  const Eigen::Vector3d t = nb.translation_mm - r * ref.translation_mm;
  *a = nb.K() * r * ref.K().inverse();
  *b = nb.K() * t;
}

}  // namespace

namespace {

// The values of ranks i and j of `values` (what std::nth_element would leave at those
// positions). A 16-bit histogram of order-preserving keys finds the
// bucket of each rank in one pass; only those buckets are then selected in, so a
// megapixel image costs two cheap passes instead of two full selections. -0 counts as 0.
std::pair<float, float> OrderStatistics(const std::vector<float>& values, size_t i, size_t j) {
  auto key = [](float f) {
    uint32_t u;
    std::memcpy(&u, &f, sizeof(u));
    if (u == 0x80000000u) u = 0;
    return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
  };
  std::vector<uint32_t> histogram(1 << 16, 0);
  for (float v : values) ++histogram[key(v) >> 16];
  auto bucket_of = [&](size_t rank, size_t* before) {
    size_t seen = 0;
    for (uint32_t b = 0;; ++b) {
      if (seen + histogram[b] > rank) {
        *before = seen;
        return b;
      }
      seen += histogram[b];
    }
  };
  size_t before_i = 0, before_j = 0;
  const uint32_t bi = bucket_of(i, &before_i), bj = bucket_of(j, &before_j);
  auto select = [&](uint32_t bucket, size_t rank) {
    std::vector<float> in;
    in.reserve(histogram[bucket]);
    for (float v : values)
      if ((key(v) >> 16) == bucket) in.push_back(v == 0.0f ? 0.0f : v);
    std::nth_element(in.begin(), in.begin() + rank, in.end());
    return in[rank];
  };
  return {select(bi, i - before_i), select(bj, j - before_j)};
}

}  // namespace

cv::Mat IdealGrey(const StereoView& view, const StereoOptions& options, const std::string& where) {
  if (view.ideal_grey.empty()) return GreyImage(view, options, /*undistort=*/true, where);
  const auto& cam = view.camera;
  core::Require(view.ideal_grey.type() == CV_32FC1 && view.ideal_grey.cols == cam.width_px &&
                    view.ideal_grey.rows == cam.height_px,
                where + ": ideal grey",
                "must be 32-bit float of the camera's " + std::to_string(cam.width_px) + "x" +
                    std::to_string(cam.height_px) + " pixels, got " +
                    std::to_string(view.ideal_grey.cols) + "x" +
                    std::to_string(view.ideal_grey.rows) + " of type code " +
                    std::to_string(view.ideal_grey.type()));
  return view.ideal_grey;
}

cv::Mat GreyImage(const StereoView& view, const StereoOptions& options, bool undistort,
                  const std::string& where) {
  const auto& cam = view.camera;
  cam.Check(where + ": camera");
  const cv::Mat& in = view.image;
  core::Require(!in.empty(), where + ": image", "is empty");
  core::Require(in.cols == cam.width_px && in.rows == cam.height_px, where + ": image",
                "must be the camera's " + std::to_string(cam.width_px) + "x" +
                    std::to_string(cam.height_px) + " pixels, got " + std::to_string(in.cols) +
                    "x" + std::to_string(in.rows));
  cv::Mat grey, valid;
  if (in.type() == CV_8UC1) {
    in.convertTo(grey, CV_32F);
  } else if (in.type() == CV_8UC3) {
    cv::Mat g;
    cv::cvtColor(in, g, cv::COLOR_BGR2GRAY);
    g.convertTo(grey, CV_32F);
  } else if (in.type() == CV_8UC4) {
    cv::Mat g;
    cv::cvtColor(in, g, cv::COLOR_BGRA2GRAY);
    g.convertTo(grey, CV_32F);
    cv::extractChannel(in, valid, 3);
  } else if (in.type() == CV_32FC1) {
    grey = in.clone();
    valid = (grey == grey);  // not NaN
    grey.setTo(0.0f, ~valid);
  } else {
    throw core::InputError(where + ": image", "must be 8-bit gray, BGR, BGRA or 32-bit float grey");
  }
  const bool all_valid = valid.empty();  // no alpha, no NaN: every pixel has data
  if (all_valid) valid = cv::Mat(grey.size(), CV_8UC1, cv::Scalar(255));
  if (undistort && cam.HasDistortion()) {
    const auto tables = geometry::SharedUndistortTables(cam);
    grey = geometry::Remap(grey, *tables);
    // All valid: where the tables reach, kept with them (read only here).
    valid = all_valid ? tables->covered : geometry::Remap(valid, *tables);
  }
  const cv::Mat invalid = valid < 255;
  if (options.normalize_contrast) {
    std::vector<float> values;
    values.reserve(grey.total());
    for (int y = 0; y < grey.rows; ++y) {
      const float* g = grey.ptr<float>(y);
      const uint8_t* m = invalid.ptr<uint8_t>(y);
      for (int x = 0; x < grey.cols; ++x)
        if (!m[x]) values.push_back(g[x]);
    }
    if (values.size() > 10) {
      const size_t i1 = values.size() / 100, i99 = values.size() * 99 / 100;
      const auto [lo, hi] = OrderStatistics(values, i1, i99);
      if (hi > lo) grey = (grey - lo) * (255.0 / (hi - lo));
    }
  }
  if (options.sqrt_greys) {
    grey = cv::min(cv::max(grey, 0.0f), 255.0f);
    cv::sqrt(grey * 255.0f, grey);
  }
  grey.setTo(std::numeric_limits<float>::quiet_NaN(), invalid);
  return grey;
}

void StereoOptions::Check() const {
  core::Require(std::isfinite(z_min_mm) && z_min_mm > 0.0, "z_min_mm",
                "must be positive, got " + std::to_string(z_min_mm));
  core::Require(std::isfinite(z_max_mm) && z_max_mm > z_min_mm, "z_max_mm",
                "must be greater than z_min_mm (" + std::to_string(z_min_mm) + "), got " +
                    std::to_string(z_max_mm));
  core::Require(num_levels == 0 || (num_levels >= 3 && num_levels <= 100000), "num_levels",
                "must be 0 (from the geometry) or 3..100000, got " + std::to_string(num_levels));
  core::Require(std::isfinite(level_step_px) && level_step_px > 0.0, "level_step_px",
                "must be positive, got " + std::to_string(level_step_px));
  core::Require(!window_sizes_px.empty(), "window_sizes_px", "must name at least one window");
  for (int w : window_sizes_px) {
    core::Require(
        w >= 1 && w <= kMaxWindowPx && w % 2 == 1, "window_sizes_px",
        "each must be odd and 1.." + std::to_string(kMaxWindowPx) + ", got " + std::to_string(w));
  }
  core::Require(std::isfinite(outside_difference_grey) && outside_difference_grey >= 0.0,
                "outside_difference_grey", "must be >= 0");
  core::Require(std::isfinite(min_curvature) && min_curvature >= 0.0, "min_curvature",
                "must be >= 0");
  core::Require(std::isfinite(min_uniqueness) && min_uniqueness >= 0.0, "min_uniqueness",
                "must be >= 0");
  core::Require(std::isfinite(min_texture_grey) && min_texture_grey >= 0.0, "min_texture_grey",
                "must be >= 0");
  core::Require(num_threads >= 0, "num_threads", "must be >= 0 (0 = all)");
  core::Require(max_simd >= 0 && max_simd <= 2, "max_simd",
                "must be 0 (scalar), 1 (AVX2) or 2 (AVX-512), got " + std::to_string(max_simd));
  speckle.Check();
}

StereoOptions RealImageOptions() {
  StereoOptions o;
  o.min_uniqueness = 0.5;
  o.window_sizes_px = {9, 13};
  return o;
}

double LevelDepthMm(double level, int num_levels, double z_min_mm, double z_max_mm) {
  const double w_far = 1.0 / z_max_mm, w_near = 1.0 / z_min_mm;
  const double w = w_far + level * (w_near - w_far) / (num_levels - 1);
  return 1.0 / w;
}

int CountDepthLevels(const geometry::TsaiCamera& reference,
                     const std::vector<geometry::TsaiCamera>& neighbours, double z_min_mm,
                     double z_max_mm, double step_px) {
  core::Require(z_min_mm > 0.0 && z_max_mm > z_min_mm, "z_min_mm",
                "must be positive and less than z_max_mm");
  core::Require(step_px > 0.0, "level_step_px", "must be positive");
  core::Require(!neighbours.empty(), "cluster", "needs at least one neighbour");
  double max_px = -1.0;
  constexpr int kGrid = 9;
  for (const auto& nb : neighbours) {
    Eigen::Matrix3d a;
    Eigen::Vector3d b;
    HomographyPieces(reference, nb, &a, &b);
    for (int gy = 0; gy < kGrid; ++gy) {
      for (int gx = 0; gx < kGrid; ++gx) {
        const Eigen::Vector3d p((reference.width_px - 1) * gx / double(kGrid - 1),
                                (reference.height_px - 1) * gy / double(kGrid - 1), 1.0);
        // Length of the epipolar segment z_max..z_min inside the neighbour's image,
        // for points in front of it: q(w) = a p + w b is linear in the inverse depth w,
        // so each condition (q_z > 0, and with it 0 <= q_x <= (W - 1) q_z and
        // 0 <= q_y <= (H - 1) q_z) holds on an interval of w, and the image of the
        // interval they share is one straight piece. (A segment that runs off the
        // image or towards the neighbour's focal plane would otherwise count thousands
        // of pixels nobody can match.)
        const Eigen::Vector3d q0 = a * p, d = b;
        double lo = 1.0 / z_max_mm, hi = 1.0 / z_min_mm;
        // Keeps the w in [lo, hi] with c0 + w c1 >= 0 (> 0 when strict).
        const auto keep = [&](double c0, double c1, bool strict) {
          if (c1 == 0.0) {
            if (strict ? !(c0 > 0.0) : !(c0 >= 0.0)) hi = lo - 1.0;  // none
            return;
          }
          const double root = -c0 / c1;
          if (c1 > 0.0) {
            lo = std::max(lo, strict ? std::nextafter(root, HUGE_VAL) : root);
          } else {
            hi = std::min(hi, strict ? std::nextafter(root, -HUGE_VAL) : root);
          }
        };
        keep(q0.z(), d.z(), true);
        keep(q0.x(), d.x(), false);
        keep((nb.width_px - 1) * q0.z() - q0.x(), (nb.width_px - 1) * d.z() - d.x(), false);
        keep(q0.y(), d.y(), false);
        keep((nb.height_px - 1) * q0.z() - q0.y(), (nb.height_px - 1) * d.z() - d.y(), false);
        double length = 0.0;
        if (lo < hi) {
          const Eigen::Vector3d qa = q0 + lo * d, qb = q0 + hi * d;
          length = (qa.head<2>() / qa.z() - qb.head<2>() / qb.z()).norm();
        }
        if (length > 0.0) max_px = std::max(max_px, length);
      }
    }
  }
  core::Require(max_px >= 0.0, "cluster",
                "no reference pixel between z_min and z_max projects into any neighbour "
                "(camera '" +
                    reference.id + "')");
  // The tolerance keeps a parallax of exactly n steps at n.
  return static_cast<int>(std::ceil(max_px / step_px - 1e-9)) + 1;
}

std::string StereoResult::BriefReport() const {
  std::ostringstream out;
  out << "stereo " << camera << ": " << num_levels << " levels, prepare " << prepare_seconds
      << " s, match " << match_seconds << " s";
  for (const auto& r : range_images) out << "; w" << r.window_px << " density " << r.density;
  out << "\n";
  return out.str();
}

StereoResult ComputeDepth(const StereoInput& input, const StereoOptions& options,
                          const TileDepths* tiles) {
  options.Check();
  core::Require(!input.neighbours.empty(), "cluster",
                "camera '" + input.reference.camera.id +
                    "' has no neighbours: multi-baseline stereo needs a cluster of at least two "
                    "cameras");
  core::Stopwatch watch;
  StereoResult result;
  result.camera = input.reference.camera.id;

  // Distortion removed once per image.
  const cv::Mat ref_nan =
      IdealGrey(input.reference, options, "reference '" + input.reference.camera.id + "'");
  std::vector<cv::Mat> nb_images;
  std::vector<geometry::TsaiCamera> nb_cams;
  for (const auto& v : input.neighbours) {
    nb_images.push_back(IdealGrey(v, options, "neighbour '" + v.camera.id + "'"));
    nb_cams.push_back(v.camera);
  }
  const auto& ref_cam = input.reference.camera;
  const int num_levels = options.num_levels > 0
                             ? options.num_levels
                             : CountDepthLevels(ref_cam, nb_cams, options.z_min_mm,
                                                options.z_max_mm, options.level_step_px);
  result.num_levels = num_levels;

  const int width = ref_cam.width_px, height = ref_cam.height_px;
  // Reference grey with invalid pixels at 0, and its invalid mask.
  const cv::Mat ref_valid = (ref_nan == ref_nan);
  cv::Mat ref_grey = ref_nan.clone();
  ref_grey.setTo(0.0f, ~ref_valid);

  KernelInput kin;
  kin.width = width;
  kin.height = height;
  kin.reference = ref_grey.ptr<float>(0);
  kin.num_levels = num_levels;
  kin.w_far = static_cast<float>(1.0 / options.z_max_mm);
  kin.w_step =
      static_cast<float>((1.0 / options.z_min_mm - 1.0 / options.z_max_mm) / (num_levels - 1));
  kin.outside_cost =
      static_cast<float>(options.outside_difference_grey * options.outside_difference_grey);
  for (size_t n = 0; n < nb_cams.size(); ++n) {
    KernelNeighbour kn;
    Eigen::Matrix3d a;
    Eigen::Vector3d b;
    HomographyPieces(ref_cam, nb_cams[n], &a, &b);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) kn.a[i][j] = a(i, j);
      kn.b[i] = b(i);
    }
    kn.image = nb_images[n].ptr<float>(0);
    kn.width = nb_images[n].cols;
    kn.height = nb_images[n].rows;
    kin.neighbours.push_back(kn);
  }
  for (int w : options.window_sizes_px) kin.half_windows.push_back(w / 2);
  kin.prewarp = options.prewarp_neighbours;
  kin.max_simd = static_cast<SimdLevel>(options.max_simd);
  if (tiles) {
    const size_t n = size_t((width + kKernelTilePx - 1) / kKernelTilePx) *
                     size_t((height + kKernelTilePx - 1) / kKernelTilePx);
    core::Require(tiles->near_mm.size() == n && tiles->far_mm.size() == n, "tile depths",
                  "expected " + std::to_string(n) + " tiles of " + std::to_string(kKernelTilePx) +
                      " px for camera '" + ref_cam.id + "', got " +
                      std::to_string(tiles->near_mm.size()) + " and " +
                      std::to_string(tiles->far_mm.size()));
    kin.tile_lo.assign(n, 1);
    kin.tile_hi.assign(n, 0);
    // Level of inverse depth w on the grid: (w - w_far) / w_step, level 0 at z_max.
    const double w_far = 1.0 / options.z_max_mm;
    const double w_step = (1.0 / options.z_min_mm - w_far) / (num_levels - 1);
    for (size_t t = 0; t < n; ++t) {
      const double near = tiles->near_mm[t], far = tiles->far_mm[t];
      if (!(near > 0.0 && near < far)) continue;
      const int lo = std::max(0, int(std::floor((1.0 / far - w_far) / w_step)) - 1);
      const int hi = std::min(num_levels - 1, int(std::ceil((1.0 / near - w_far) / w_step)) + 1);
      if (lo > hi) continue;
      kin.tile_lo[t] = lo;
      kin.tile_hi[t] = hi;
      ++result.tiles_searched;
      result.tile_levels += hi - lo + 1;
    }
  }
  result.prepare_seconds = watch.ElapsedSeconds();
  watch.Restart();

  std::vector<KernelOutput> outs(options.window_sizes_px.size());
  for (auto& o : outs) {
    o.best_level.assign(size_t(width) * height, -1.0f);
    o.curvature.assign(size_t(width) * height, 0.0f);
    o.best_cost.assign(size_t(width) * height, 0.0f);
    o.second_cost.assign(size_t(width) * height, 0.0f);
    o.offset.assign(size_t(width) * height, 0.0f);
  }
  RunCostKernel(kin, options.num_threads, &outs);
  result.match_seconds = watch.ElapsedSeconds();

  // Validity and depth per window size.
  const int nn = static_cast<int>(nb_cams.size());
  for (size_t k = 0; k < options.window_sizes_px.size(); ++k) {
    const int wpx = options.window_sizes_px[k];
    const double samples = double(wpx) * wpx * nn;
    cv::Mat invalid_f, mean, mean2;
    cv::Mat(~ref_valid).convertTo(invalid_f, CV_32F, 1.0 / 255.0);
    cv::boxFilter(invalid_f, invalid_f, CV_32F, cv::Size(wpx, wpx), cv::Point(-1, -1), false,
                  cv::BORDER_CONSTANT);
    cv::boxFilter(ref_grey, mean, CV_32F, cv::Size(wpx, wpx));
    cv::boxFilter(ref_grey.mul(ref_grey), mean2, CV_32F, cv::Size(wpx, wpx));
    RangeImage ri;
    ri.window_px = wpx;
    ri.depth_mm = cv::Mat(height, width, CV_32FC1, cv::Scalar(0));
    ri.reliability = cv::Mat(height, width, CV_32FC1, cv::Scalar(0));
    const KernelOutput& o = outs[k];
    int64_t n_valid = 0;
    const double min_var = options.min_texture_grey * options.min_texture_grey;
    for (int y = 0; y < height; ++y) {
      float* d = ri.depth_mm.ptr<float>(y);
      float* r = ri.reliability.ptr<float>(y);
      for (int x = 0; x < width; ++x) {
        const size_t i = size_t(y) * width + x;
        const float bl = o.best_level[i];
        if (!(bl >= 1.0f && bl <= num_levels - 2.0f)) continue;
        if (invalid_f.at<float>(y, x) > 0.0f) continue;
        const double var =
            mean2.at<float>(y, x) - double(mean.at<float>(y, x)) * mean.at<float>(y, x);
        if (var < min_var) continue;
        const double curvature = o.curvature[i] / samples;
        if (!(curvature >= options.min_curvature) || curvature <= 0.0) continue;
        const double best = o.best_cost[i], second = o.second_cost[i];
        if (!(second - best > options.min_uniqueness * (best + samples))) continue;
        const double level = bl + o.offset[i];
        const double z = LevelDepthMm(level, num_levels, options.z_min_mm, options.z_max_mm);
        if (!(std::isfinite(z) && z > 0.0)) continue;
        d[x] = static_cast<float>(z);
        r[x] = static_cast<float>(curvature);
        ++n_valid;
      }
    }
    n_valid -= RemoveSpeckles(options.speckle, &ri.depth_mm, &ri.reliability);
    ri.density = double(n_valid) / (double(width) * height);
    result.range_images.push_back(std::move(ri));
  }
  return result;
}

}  // namespace dome::stereo
