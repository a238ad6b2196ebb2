#include "stereo/coarse_to_fine.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <string>
#include <utility>
#include <vector>

#include "core/error.h"
#include "core/parallel_for.h"
#include "core/timer.h"
#include "stereo/cost_kernel.h"
#include "take/crop.h"

namespace dome::stereo {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

}  // namespace

cv::Mat ReduceGrey(const cv::Mat& grey, int factor) {
  const cv::Size size(grey.cols / factor, grey.rows / factor);
  const cv::Rect used(0, 0, size.width * factor, size.height * factor);
  const cv::Mat valid = grey(used) == grey(used);
  cv::Mat filled = grey(used).clone(), valid_f;
  filled.setTo(0.0f, ~valid);
  valid.convertTo(valid_f, CV_32F, 1.0 / 255.0);
  cv::Mat out, coverage;
  cv::resize(filled, out, size, 0, 0, cv::INTER_AREA);
  cv::resize(valid_f, coverage, size, 0, 0, cv::INTER_AREA);
  out.setTo(kNaN, coverage < 1.0f - 1e-4f);
  return out;
}

namespace {

// The bounding rectangle in `nb` of the rectangle `rect` of the reference image seen at
// depths z0 and z1 (every point between projects inside it), grown by `margin_px` and
// clipped to the image; a few pixels at the image corner when nothing is in view (a
// neighbour that sees nothing then costs as little as it can).
cv::Rect NeighbourRect(const geometry::TsaiCamera& ref, const geometry::TsaiCamera& nb,
                       const cv::Rect& rect, double z0, double z1, int margin_px) {
  double lo_u = std::numeric_limits<double>::infinity(), lo_v = lo_u, hi_u = -lo_u, hi_v = -lo_u;
  for (int c = 0; c < 4; ++c) {
    const Eigen::Vector2d px(c & 1 ? rect.x + rect.width : rect.x - 1.0,
                             c & 2 ? rect.y + rect.height : rect.y - 1.0);
    for (double z : {z0, z1}) {
      Eigen::Vector2d q;
      if (!nb.Project(ref.BackProjectAtDepth(px, z), &q)) continue;
      lo_u = std::min(lo_u, q.x());
      hi_u = std::max(hi_u, q.x());
      lo_v = std::min(lo_v, q.y());
      hi_v = std::max(hi_v, q.y());
    }
  }
  const cv::Rect image(0, 0, nb.width_px, nb.height_px);
  cv::Rect r;
  if (lo_u <= hi_u && lo_v <= hi_v) {
    const double x0 = std::max(-1.0, std::floor(lo_u) - margin_px);
    const double y0 = std::max(-1.0, std::floor(lo_v) - margin_px);
    const double x1 = std::min(double(nb.width_px) + 1, std::ceil(hi_u) + margin_px + 1);
    const double y1 = std::min(double(nb.height_px) + 1, std::ceil(hi_v) + margin_px + 1);
    if (x1 > x0 && y1 > y0) r = cv::Rect(int(x0), int(y0), int(x1 - x0), int(y1 - y0)) & image;
  }
  if (r.width < 4 || r.height < 4) r = cv::Rect(0, 0, 4, 4) & image;
  return r;
}

}  // namespace

void CoarseToFineOptions::Check() const {
  core::Require(coarse_factor >= 2 && coarse_factor <= 16, "coarse_to_fine.coarse_factor",
                "must be in 2..16, got " + std::to_string(coarse_factor));
  core::Require(coarse_window_px >= 1 && coarse_window_px % 2 == 1 && coarse_window_px <= 31,
                "coarse_to_fine.coarse_window_px",
                "must be odd, 1..31, got " + std::to_string(coarse_window_px));
  core::Require(tile_px >= 8, "coarse_to_fine.tile_px",
                "must be at least 8 px, got " + std::to_string(tile_px));
  core::Require(std::isfinite(margin_levels) && margin_levels > 0, "coarse_to_fine.margin_levels",
                "must be positive, got " + std::to_string(margin_levels));
  core::Require(trim_fraction >= 0 && trim_fraction < 0.5, "coarse_to_fine.trim_fraction",
                "must be in [0, 0.5), got " + std::to_string(trim_fraction));
  core::Require(std::isfinite(coarse_min_uniqueness) && coarse_min_uniqueness >= 0,
                "coarse_to_fine.coarse_min_uniqueness",
                "must be >= 0, got " + std::to_string(coarse_min_uniqueness));
  core::Require(min_coarse_depths >= 1, "coarse_to_fine.min_coarse_depths",
                "must be at least 1, got " + std::to_string(min_coarse_depths));
  core::Require(fill_min_neighbours >= 0 && fill_min_neighbours <= 8,
                "coarse_to_fine.fill_min_neighbours",
                "must be in 0..8 (0: no filling), got " + std::to_string(fill_min_neighbours));
  if (clip) {
    for (int i = 0; i < 3; ++i) {
      core::Require(std::isfinite(clip_min_mm[i]) && std::isfinite(clip_max_mm[i]) &&
                        clip_min_mm[i] < clip_max_mm[i],
                    "coarse_to_fine.clip_max_mm",
                    "each coordinate must exceed clip_min_mm's, got " +
                        std::to_string(clip_max_mm[i]) + " <= " + std::to_string(clip_min_mm[i]) +
                        " (axis " + std::to_string(i) + ")");
    }
  }
  core::Require(std::isfinite(clip_pad_mm) && clip_pad_mm >= 0, "coarse_to_fine.clip_pad_mm",
                "must be >= 0 mm, got " + std::to_string(clip_pad_mm));
}

void ClipDepthRange(const CoarseToFineOptions& c2f, const geometry::TsaiCamera& camera,
                    const std::string& where, StereoOptions* o) {
  if (!c2f.clip) return;
  ClipDepthRangeToBox(c2f.clip_min_mm, c2f.clip_max_mm, c2f.clip_pad_mm, camera,
                      where + ": coarse_to_fine.clip_min_mm", o);
}

namespace {
// The options' range intersected with [z_lo, z_hi]; an empty one is refused naming `field`.
void NarrowDepthRange(double z_lo, double z_hi, const geometry::TsaiCamera& camera,
                      const std::string& field, StereoOptions* o) {
  const double z_min = std::max(o->z_min_mm, z_lo);
  const double z_max = std::min(o->z_max_mm, z_hi);
  core::Require(z_min < z_max, field,
                "camera '" + camera.id + "' sees no depth of the clip box within [" +
                    std::to_string(o->z_min_mm) + ", " + std::to_string(o->z_max_mm) + "] mm");
  o->z_min_mm = z_min;
  o->z_max_mm = z_max;
}
}  // namespace

void ClipDepthRangeToBox(const Eigen::Vector3d& box_min_mm, const Eigen::Vector3d& box_max_mm,
                         double pad_mm, const geometry::TsaiCamera& camera,
                         const std::string& field, StereoOptions* o) {
  double z_lo = std::numeric_limits<double>::infinity();
  double z_hi = -std::numeric_limits<double>::infinity();
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d p(c & 1 ? box_max_mm(0) : box_min_mm(0),
                            c & 2 ? box_max_mm(1) : box_min_mm(1),
                            c & 4 ? box_max_mm(2) : box_min_mm(2));
    const double z = camera.WorldToCamera(p).z();
    z_lo = std::min(z_lo, z);
    z_hi = std::max(z_hi, z);
  }
  NarrowDepthRange(z_lo - pad_mm, z_hi + pad_mm, camera, field, o);
}

namespace {

// The least and greatest depth (z, mm) of the box's sample points that `camera` sees
// (z_lo > z_hi when it sees none): a grid of kSamples + 1 points per box edge, each
// projected through the lens. Every stereo job of a camera asks with the session's one
// box (the paper take: each of 51 cameras at 11 instants), and the projections were 4 %
// of a masked paper job: kept for the process, keyed by the camera's every number
// (TsaiCamera::Key) and the box; the same result as computing it.
constexpr int kSamples = 24;  // per box edge

std::pair<double, double> VisibleDepths(const Eigen::Vector3d& box_min_mm,
                                        const Eigen::Vector3d& box_max_mm,
                                        const geometry::TsaiCamera& camera) {
  const double box[] = {box_min_mm(0), box_min_mm(1), box_min_mm(2),
                        box_max_mm(0), box_max_mm(1), box_max_mm(2)};
  const std::string key =
      camera.Key() + std::string(reinterpret_cast<const char*>(box), sizeof box);
  static std::mutex mutex;
  static std::map<std::string, std::pair<double, double>> kept;
  constexpr size_t kMaxKept = 4096;  // cameras x boxes; 1024 cameras of 4 sessions
  {
    std::lock_guard<std::mutex> lock(mutex);
    const auto it = kept.find(key);
    if (it != kept.end()) return it->second;
  }
  const Eigen::Vector3d step = (box_max_mm - box_min_mm) / kSamples;
  double z_lo = std::numeric_limits<double>::infinity();
  double z_hi = -std::numeric_limits<double>::infinity();
  for (int k = 0; k <= kSamples; ++k) {
    for (int j = 0; j <= kSamples; ++j) {
      for (int i = 0; i <= kSamples; ++i) {
        const Eigen::Vector3d p = box_min_mm + step.cwiseProduct(Eigen::Vector3d(i, j, k));
        Eigen::Vector2d px;
        if (!camera.Project(p, &px) || px.x() < -0.5 || px.y() < -0.5 ||
            px.x() > camera.width_px - 0.5 || px.y() > camera.height_px - 0.5)
          continue;
        const double z = camera.WorldToCamera(p).z();
        z_lo = std::min(z_lo, z);
        z_hi = std::max(z_hi, z);
      }
    }
  }
  std::lock_guard<std::mutex> lock(mutex);
  if (kept.size() >= kMaxKept) kept.clear();
  kept.emplace(key, std::make_pair(z_lo, z_hi));
  return {z_lo, z_hi};
}

}  // namespace

void ClipDepthRangeToVisibleBox(const Eigen::Vector3d& box_min_mm,
                                const Eigen::Vector3d& box_max_mm, double pad_mm,
                                const geometry::TsaiCamera& camera, const std::string& field,
                                StereoOptions* o) {
  const auto [z_lo, z_hi] = VisibleDepths(box_min_mm, box_max_mm, camera);
  // A visible point of the box lies within half a sample diagonal of a sample.
  const double slack = 0.5 * ((box_max_mm - box_min_mm) / kSamples).norm() + pad_mm;
  NarrowDepthRange(z_lo - slack, z_hi + slack, camera, field, o);
}

geometry::TsaiCamera ReducedCamera(const geometry::TsaiCamera& camera, int factor) {
  geometry::TsaiCamera c = camera;
  // Coarse pixel i is centred on fine pixel factor i + (factor - 1) / 2.
  c.sensor.dx_mm *= factor;
  c.sensor.dy_mm *= factor;
  c.cx_px = (camera.cx_px + 0.5) / factor - 0.5;
  c.cy_px = (camera.cy_px + 0.5) / factor - 0.5;
  c.width_px = camera.width_px / factor;
  c.height_px = camera.height_px / factor;
  return c;
}

namespace {

// Every view's grey, undistorted, and its ideal camera (the reference first).
struct IdealViews {
  std::vector<const StereoView*> views;
  std::vector<cv::Mat> greys;
  std::vector<geometry::TsaiCamera> cameras;
};

IdealViews MakeIdealViews(const StereoInput& input, const StereoOptions& options) {
  IdealViews iv;
  std::vector<const StereoView*>& views = iv.views;
  std::vector<cv::Mat>& greys = iv.greys;
  std::vector<geometry::TsaiCamera>& cameras = iv.cameras;
  // Greys once per image, stretched over the whole image and undistorted once (as
  // ComputeDepth does: the lens removed, then the grey mapping), so that the coarse pass
  // and every tile match ideal images with the ideal cameras: no tile builds remap tables
  // for its crop or resamples it, and a tile's border keeps the data its crop alone could
  // not undistort (on a 1920x1080 Panoptic camera, 0.71x the job's CPU time and twice
  // its depths).
  views = {&input.reference};
  for (const auto& v : input.neighbours) views.push_back(&v);
  for (size_t i = 0; i < views.size(); ++i) {
    views[i]->camera.Check("view '" + views[i]->camera.id + "': camera");
    cameras.push_back(views[i]->camera.Ideal());
  }
  // Side by side: each grey is one thread's work (the stretch's percentiles are of the
  // whole image), and the job's other threads would wait.
  greys.resize(views.size());
  core::ParallelFor(0, int64_t(views.size()), options.num_threads, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      greys[size_t(i)] = IdealGrey(*views[size_t(i)], options,
                                   (i == 0 ? "reference '" : "neighbour '") +
                                       views[size_t(i)]->camera.id + "'");
    }
  });
  return iv;
}

// A tile of the reference image and the depths it searches (z, mm).
struct TileJob {
  cv::Rect tile;
  double z_lo, z_hi;
};

// The result's range images, one per window size, without depths.
StereoResult EmptyResult(const std::string& camera, const StereoOptions& options, int width,
                         int height) {
  StereoResult result;
  result.camera = camera;
  for (int w : options.window_sizes_px) {
    RangeImage ri;
    ri.window_px = w;
    ri.depth_mm = cv::Mat(height, width, CV_32FC1, cv::Scalar(0));
    ri.reliability = cv::Mat(height, width, CV_32FC1, cv::Scalar(0));
    result.range_images.push_back(std::move(ri));
  }
  return result;
}

// Matches every tile of `jobs` at full resolution over its own depths, writing its
// pixels of `result`; counts into `st`.
void MatchTiles(const IdealViews& iv, const StereoOptions& options,
                const std::vector<TileJob>& jobs, StereoResult* out, CoarseToFineStats* out_st) {
  const std::vector<const StereoView*>& views = iv.views;
  const std::vector<cv::Mat>& greys = iv.greys;
  const std::vector<geometry::TsaiCamera>& cameras = iv.cameras;
  const geometry::TsaiCamera& ideal_ref = cameras[0];
  StereoResult& result = *out;
  CoarseToFineStats& st = *out_st;
  const int width = ideal_ref.width_px, height = ideal_ref.height_px;
  const cv::Rect image(0, 0, width, height);
  const int half =
      *std::max_element(options.window_sizes_px.begin(), options.window_sizes_px.end()) / 2;
  const double w_range = 1.0 / options.z_min_mm - 1.0 / options.z_max_mm;
  // Tiles are small: one thread each, each thread taking the next tile when it is done
  // with one, the dearest first (pixels times the inverse-depth range its levels span),
  // so that no thread is left with a long tile while the other waits. Each tile writes
  // only its own pixels of the result, so the order changes no output.
  const int threads = std::max(
      1,
      int(std::min<int64_t>(options.num_threads > 0 ? options.num_threads : core::HardwareThreads(),
                            int64_t(jobs.size()))));
  std::vector<size_t> order(jobs.size());
  for (size_t j = 0; j < jobs.size(); ++j) order[j] = j;
  const auto cost = [&](size_t j) {
    return double(jobs[j].tile.area()) * (1.0 / jobs[j].z_lo - 1.0 / jobs[j].z_hi);
  };
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return cost(a) > cost(b); });
  std::atomic<size_t> next{0};
  struct SlotStats {
    int matched = 0, max_levels = 0;
    double level_sum = 0, prepare_seconds = 0, match_seconds = 0;
  };
  std::vector<SlotStats> slots(static_cast<size_t>(threads));
  core::ParallelFor(0, threads, threads, [&](int64_t s0, int64_t s1) {
    for (int64_t slot = s0; slot < s1; ++slot) {
      SlotStats& ss = slots[size_t(slot)];
      for (size_t k = next++; k < jobs.size(); k = next++) {
        const TileJob& job = jobs[order[k]];
        const cv::Rect ref_rect =
            cv::Rect(job.tile.x - half - 1, job.tile.y - half - 1, job.tile.width + 2 * half + 2,
                     job.tile.height + 2 * half + 2) &
            image;
        // Views of the greys, not copies: ComputeDepth copies what it matches.
        StereoInput in;
        in.reference = {take::CropCamera(ideal_ref, ref_rect), greys[0](ref_rect), {}};
        for (size_t i = 1; i < views.size(); ++i) {
          const cv::Rect r = NeighbourRect(ideal_ref, cameras[i], ref_rect, job.z_lo, job.z_hi, 4);
          in.neighbours.push_back({take::CropCamera(cameras[i], r), greys[i](r), {}});
        }
        StereoOptions o = options;
        o.normalize_contrast = false;
        o.sqrt_greys = false;
        o.num_threads = 1;
        o.speckle = {};  // over the whole image below: a piece may span tiles
        o.z_min_mm = job.z_lo;
        o.z_max_mm = job.z_hi;
        if (options.num_levels > 0) {
          o.num_levels = std::max(
              5,
              int(std::ceil(options.num_levels * (1.0 / job.z_lo - 1.0 / job.z_hi) / w_range)) + 1);
        } else {
          std::vector<geometry::TsaiCamera> nb;
          for (const auto& v : in.neighbours) nb.push_back(v.camera);
          try {
            o.num_levels = std::max(5, CountDepthLevels(in.reference.camera, nb, job.z_lo, job.z_hi,
                                                        options.level_step_px));
          } catch (const core::InputError&) {
            continue;  // no neighbour sees this tile: nothing to match
          }
        }
        const StereoResult r = ComputeDepth(in, o);
        ++ss.matched;
        ss.max_levels = std::max(ss.max_levels, r.num_levels);
        ss.level_sum += r.num_levels;
        ss.prepare_seconds += r.prepare_seconds;
        ss.match_seconds += r.match_seconds;
        const cv::Rect inner(job.tile.x - ref_rect.x, job.tile.y - ref_rect.y, job.tile.width,
                             job.tile.height);
        for (size_t k = 0; k < r.range_images.size(); ++k) {
          r.range_images[k].depth_mm(inner).copyTo(result.range_images[k].depth_mm(job.tile));
          r.range_images[k].reliability(inner).copyTo(result.range_images[k].reliability(job.tile));
        }
      }
    }
  });
  for (const SlotStats& ss : slots) {
    result.num_levels = std::max(result.num_levels, ss.max_levels);
    result.prepare_seconds += ss.prepare_seconds;
    result.match_seconds += ss.match_seconds;
    st.tiles_matched += ss.matched;
    st.mean_tile_levels += ss.level_sum;
  }
}

// Speckles removed (after the bounds: a piece the bounds cut is judged by what is left)
// and the densities counted.
void FinishResult(const StereoOptions& options, const SearchBounds* bounds,
                  StereoResult* result) {
  for (auto& ri : result->range_images) {
    if (bounds) bounds->Apply(&ri.depth_mm, &ri.reliability);
    RemoveSpeckles(options.speckle, &ri.depth_mm, &ri.reliability);
    ri.density = double(cv::countNonZero(ri.depth_mm)) / double(ri.depth_mm.total());
  }
}

}  // namespace

StereoResult ComputeDepthCoarseToFine(const StereoInput& input, const StereoOptions& options,
                                      const CoarseToFineOptions& c2f, CoarseToFineStats* stats,
                                      const SearchBounds* bounds) {
  core::Stopwatch watch;
  CoarseToFineStats st;
  options.Check();
  c2f.Check();
  core::Require(!input.neighbours.empty(), "cluster",
                "camera '" + input.reference.camera.id + "' has no neighbours");
  const int f = c2f.coarse_factor;
  const auto& ref_cam = input.reference.camera;
  ref_cam.Check("reference '" + ref_cam.id + "': camera");
  if (bounds) {
    bounds->Check(cv::Size(ref_cam.width_px, ref_cam.height_px),
                  "search bounds of '" + ref_cam.id + "'");
  }
  core::Require(ref_cam.width_px >= 4 * f && ref_cam.height_px >= 4 * f,
                "reference '" + ref_cam.id + "'",
                "image too small for a coarse pass reduced " + std::to_string(f) + " times");

  const IdealViews iv = MakeIdealViews(input, options);
  const std::vector<const StereoView*>& views = iv.views;
  const std::vector<cv::Mat>& greys = iv.greys;
  const std::vector<geometry::TsaiCamera>& cameras = iv.cameras;
  const geometry::TsaiCamera& ideal_ref = cameras[0];

  // 1. Coarse pass over the whole range.
  StereoInput coarse;
  std::vector<cv::Mat> reduced(views.size());
  core::ParallelFor(0, int64_t(views.size()), options.num_threads, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) reduced[size_t(i)] = ReduceGrey(greys[size_t(i)], f);
  });
  coarse.reference = {ReducedCamera(ideal_ref, f), reduced[0], {}};
  for (size_t i = 1; i < views.size(); ++i) {
    coarse.neighbours.push_back({ReducedCamera(cameras[i], f), reduced[i], {}});
  }
  StereoOptions coarse_options = options;
  coarse_options.normalize_contrast = false;  // the greys above are mapped already
  coarse_options.sqrt_greys = false;
  coarse_options.window_sizes_px = {c2f.coarse_window_px};
  coarse_options.speckle = {};  // stray coarse depths are trimmed per tile instead
  if (c2f.coarse_min_uniqueness > 0) coarse_options.min_uniqueness = c2f.coarse_min_uniqueness;
  if (options.num_levels > 0) coarse_options.num_levels = std::max(3, options.num_levels / f);
  const StereoResult coarse_result = ComputeDepth(coarse, coarse_options);
  cv::Mat coarse_depth = coarse_result.range_images[0].depth_mm;
  if (c2f.clip) {
    // The clip box bounds the scene: a coarse depth whose point lies outside it (grown by
    // clip_pad_mm) is a wrong match or the background (a table, the walls), and would make
    // its tile search depths no surface of the box has (or search a tile that sees none).
    const Eigen::Vector3d lo = c2f.clip_min_mm.array() - c2f.clip_pad_mm;
    const Eigen::Vector3d hi = c2f.clip_max_mm.array() + c2f.clip_pad_mm;
    for (int y = 0; y < coarse_depth.rows; ++y) {
      float* d = coarse_depth.ptr<float>(y);
      for (int x = 0; x < coarse_depth.cols; ++x) {
        if (!(d[x] > 0)) continue;
        const Eigen::Vector3d p =
            coarse.reference.camera.BackProjectAtDepth(Eigen::Vector2d(x, y), d[x]);
        if ((p.array() < lo.array()).any() || (p.array() > hi.array()).any()) d[x] = 0;
      }
    }
  }
  // Inverse depth per coarse level, 1/mm.
  const double coarse_w_step =
      (1.0 / options.z_min_mm - 1.0 / options.z_max_mm) / std::max(1, coarse_result.num_levels - 1);

  st.coarse_levels = coarse_result.num_levels;
  st.coarse_seconds = watch.ElapsedSeconds();
  watch.Restart();

  // 2. Fine pass per tile.
  const int width = ref_cam.width_px, height = ref_cam.height_px;
  StereoResult result = EmptyResult(ref_cam.id, options, width, height);
  const int half =
      *std::max_element(options.window_sizes_px.begin(), options.window_sizes_px.end()) / 2;
  const cv::Rect image(0, 0, width, height);
  // The tiles to search and their depth bounds.
  std::vector<TileJob> jobs;
  std::vector<float> depths;
  const int tiles_x = (width + c2f.tile_px - 1) / c2f.tile_px;
  const int tiles_y = (height + c2f.tile_px - 1) / c2f.tile_px;
  std::vector<int> job_of(size_t(tiles_x) * tiles_y, -1);  // tile -> jobs index, -1: none
  for (int ty = 0; ty < height; ty += c2f.tile_px) {
    for (int tx = 0; tx < width; tx += c2f.tile_px) {
      const cv::Rect tile = cv::Rect(tx, ty, c2f.tile_px, c2f.tile_px) & image;
      const size_t tile_index = size_t(ty / c2f.tile_px) * tiles_x + tx / c2f.tile_px;
      // Coarse depths over the tile, its windows and one coarse pixel more.
      const int g = half + f;
      const cv::Rect around =
          cv::Rect((tile.x - g) / f, (tile.y - g) / f, (tile.width + 2 * g) / f + 2,
                   (tile.height + 2 * g) / f + 2) &
          cv::Rect(0, 0, coarse_depth.cols, coarse_depth.rows);
      depths.clear();
      for (int y = std::max(0, around.y); y < around.br().y; ++y) {
        const float* d = coarse_depth.ptr<float>(y);
        for (int x = std::max(0, around.x); x < around.br().x; ++x) {
          if (d[x] > 0) depths.push_back(d[x]);
        }
      }
      ++st.tiles;
      if (depths.size() < size_t(c2f.min_coarse_depths)) continue;
      const size_t trim = size_t(c2f.trim_fraction * double(depths.size()));
      std::nth_element(depths.begin(), depths.begin() + trim, depths.end());
      const double near_z = depths[trim];
      std::nth_element(depths.begin(), depths.end() - 1 - trim, depths.end());
      const double far_z = depths[depths.size() - 1 - trim];
      const double margin_w = c2f.margin_levels * coarse_w_step;
      const double z_lo = std::max(options.z_min_mm, 1.0 / (1.0 / near_z + margin_w));
      const double far_w = 1.0 / far_z - margin_w;
      const double z_hi = far_w > 0 ? std::min(options.z_max_mm, 1.0 / far_w) : options.z_max_mm;
      if (z_hi > z_lo) {
        job_of[tile_index] = int(jobs.size());
        jobs.push_back({tile, z_lo, z_hi});
      }
    }
  }
  // Each tile searches only the part of its range its pixels' bounds allow.
  const auto within_bounds = [&](std::vector<TileJob> js) {
    if (!bounds) return js;
    std::vector<TileJob> kept;
    for (TileJob job : js) {
      double near_mm, far_mm;
      if (!bounds->Range(job.tile, &near_mm, &far_mm)) continue;
      job.z_lo = std::max(job.z_lo, near_mm);
      job.z_hi = std::min(job.z_hi, far_mm);
      if (job.z_lo < job.z_hi) kept.push_back(job);
    }
    return kept;
  };
  MatchTiles(iv, options, within_bounds(jobs), &result, &st);
  // Tiles without coarse depths, beside searched ones whose surface reaches them, search
  // the union of those tiles' bounds. A neighbour's surface reaches a tile when its
  // fine depths hold at least `strip` pixels within `strip` of the tile (along the
  // shared edge, or in the shared corner): most tiles beside a searched one are
  // background that matches nothing, and a surface that goes on across an edge shows at
  // the edge. On Robovision 12_11_32 every tile beside a searched one was filled: 1,054
  // of the 2,154 tiles searched, most of them finding no depth; with this rule 78 of
  // 1,178.
  if (c2f.fill_min_neighbours > 0) {
    const int strip = std::max(1, c2f.tile_px / 8);
    // The searched tiles' surface without its specks (stray matches in the background
    // reach every edge).
    std::vector<cv::Mat> surface;
    for (const RangeImage& ri : result.range_images) {
      cv::Mat depth = ri.depth_mm.clone(), reliability = ri.reliability.clone();
      RemoveSpeckles(options.speckle, &depth, &reliability);
      surface.push_back(depth);
    }
    std::vector<TileJob> fill;
    for (int by = 0; by < tiles_y; ++by) {
      for (int bx = 0; bx < tiles_x; ++bx) {
        if (job_of[size_t(by) * tiles_x + bx] >= 0) continue;
        const cv::Rect tile =
            cv::Rect(bx * c2f.tile_px, by * c2f.tile_px, c2f.tile_px, c2f.tile_px) & image;
        const cv::Rect near_tile(tile.x - strip, tile.y - strip, tile.width + 2 * strip,
                                 tile.height + 2 * strip);
        int count = 0;
        double z_lo = options.z_max_mm, z_hi = options.z_min_mm;
        for (int ny = std::max(0, by - 1); ny <= std::min(tiles_y - 1, by + 1); ++ny) {
          for (int nx = std::max(0, bx - 1); nx <= std::min(tiles_x - 1, bx + 1); ++nx) {
            const int j = job_of[size_t(ny) * tiles_x + nx];
            if (j < 0) continue;
            const cv::Rect edge = jobs[size_t(j)].tile & near_tile;
            int found = 0;
            for (const cv::Mat& depth : surface) {
              found = std::max(found, cv::countNonZero(depth(edge)));
            }
            if (found < strip) continue;
            ++count;
            z_lo = std::min(z_lo, jobs[size_t(j)].z_lo);
            z_hi = std::max(z_hi, jobs[size_t(j)].z_hi);
          }
        }
        if (count < c2f.fill_min_neighbours) continue;
        fill.push_back({tile, z_lo, z_hi});
      }
    }
    fill = within_bounds(std::move(fill));
    st.tiles_filled = int(fill.size());
    MatchTiles(iv, options, fill, &result, &st);
  }
  st.fine_seconds = watch.ElapsedSeconds();
  if (st.tiles_matched > 0) st.mean_tile_levels /= st.tiles_matched;
  if (stats) *stats = st;
  FinishResult(options, bounds, &result);
  return result;
}

StereoResult ComputeDepthBounded(const StereoInput& input, const StereoOptions& options,
                                 const SearchBounds& bounds, CoarseToFineStats* stats) {
  core::Stopwatch watch;
  options.Check();
  core::Require(!input.neighbours.empty(), "cluster",
                "camera '" + input.reference.camera.id + "' has no neighbours");
  const auto& ref_cam = input.reference.camera;
  ref_cam.Check("reference '" + ref_cam.id + "': camera");
  bounds.Check(cv::Size(ref_cam.width_px, ref_cam.height_px),
               "search bounds of '" + ref_cam.id + "'");
  const IdealViews iv = MakeIdealViews(input, options);
  CoarseToFineStats st;
  st.coarse_seconds = watch.ElapsedSeconds();
  watch.Restart();
  const int width = ref_cam.width_px, height = ref_cam.height_px;
  StereoResult result = EmptyResult(ref_cam.id, options, width, height);
  // Per tile of the kernel's size, the depths its searched pixels allow (the least near ..
  // greatest far of them, within the options' range); tiles without one search nothing.
  TileDepths tiles;
  std::vector<TileJob> jobs;
  for (int ty = 0; ty < height; ty += kKernelTilePx) {
    for (int tx = 0; tx < width; tx += kKernelTilePx) {
      ++st.tiles;
      // The tile cut to the rectangle of its searched pixels (for a search per tile: at a
      // silhouette's edge most of a tile is background, and a tile costs its pixels and
      // their window margin x its levels; the pixels cut off have no depth either way).
      const cv::Rect tile = bounds.SearchedRect(cv::Rect(tx, ty, kKernelTilePx, kKernelTilePx) &
                                                cv::Rect(0, 0, width, height));
      double near_mm = 0, far_mm = 0;
      if (!tile.empty() && bounds.Range(tile, &near_mm, &far_mm)) {
        near_mm = std::max(options.z_min_mm, near_mm);
        far_mm = std::min(options.z_max_mm, far_mm);
        if (near_mm < far_mm) jobs.push_back({tile, near_mm, far_mm});
      }
      tiles.near_mm.push_back(float(near_mm));
      tiles.far_mm.push_back(float(far_mm));
    }
  }
  // Where at least half of the tiles search (the previous instant's depths bound most of
  // the image), one kernel pass over the whole images: the neighbours are resampled
  // once for all of them. Where few do (a silhouette's), each tile alone, over its own
  // level grid (the levels its cut of the cameras needs, fewer than the whole image's),
  // resampling only what it sees. Measured on the synthetic dome's paper take, matching
  // seconds over the 51 cameras of an instant: with the previous instant's bounds (every
  // tile searched) 1.4 in one pass against 4.8 tile by tile (tiles over the whole range
  // fell back to the exact warp); with a silhouette's (10-15 tiles in 80) 0.25 in one
  // pass against 0.15.
  if (2 * jobs.size() >= size_t(st.tiles)) {
    StereoInput in;
    in.reference = {iv.cameras[0], iv.greys[0], iv.greys[0]};
    for (size_t i = 1; i < iv.views.size(); ++i) {
      in.neighbours.push_back({iv.cameras[i], iv.greys[i], iv.greys[i]});
    }
    StereoOptions o = options;
    o.speckle = {};  // after the bounds, below
    bool seen = true;
    if (o.num_levels <= 0) {
      const std::vector<geometry::TsaiCamera> nb(iv.cameras.begin() + 1, iv.cameras.end());
      try {
        o.num_levels = CountDepthLevels(iv.cameras[0], nb, o.z_min_mm, o.z_max_mm, o.level_step_px);
      } catch (const core::InputError&) {
        seen = false;  // no neighbour sees the range: nothing to match
      }
    }
    if (seen) {
      StereoResult r = ComputeDepth(in, o, &tiles);
      r.camera = ref_cam.id;
      st.tiles_matched = int(r.tiles_searched);
      st.mean_tile_levels = double(r.tile_levels);
      result = std::move(r);
    }
  } else {
    MatchTiles(iv, options, jobs, &result, &st);
  }
  st.fine_seconds = watch.ElapsedSeconds();
  if (st.tiles_matched > 0) st.mean_tile_levels /= st.tiles_matched;
  if (stats) *stats = st;
  FinishResult(options, &bounds, &result);
  return result;
}

}  // namespace dome::stereo
