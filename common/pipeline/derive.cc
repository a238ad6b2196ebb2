#include "pipeline/derive.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "core/error.h"
#include "core/parallel_for.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "net/content_hash.h"
#include "pipeline/frame_handoff.h"
#include "pipeline/session.h"
#include "pipeline/settings.h"
#include "silhouette/hull.h"
#include "silhouette/take_masks.h"
#include "stereo/cluster.h"
#include "stereo/scene_extent.h"
#include "stereo/take_stereo.h"

namespace dome::pipeline {
namespace {

std::string Box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  return fmt::format("[{:.1f} {:.1f} {:.1f}] .. [{:.1f} {:.1f} {:.1f}] mm", lo.x(), lo.y(), lo.z(),
                     hi.x(), hi.y(), hi.z());
}

// The frame files the derivation reads, each decoded once for all its steps: the
// greys, the masks (the median background reads every camera's frames at its instants,
// then each mask its own frame again), the scene's extent and the masks' hull. On a
// Panoptic take each HD frame was decoded three times, a tenth of the derivation.
// Images are held while their pixels stay within kDerivationFramesBytes (the rest are
// decoded again where needed, as before); the SHA-256 of every file read (the address
// the in-process workers' handoff keys frames by) is kept. Thread-safe. Keyed by path
// and dropped when the derivation ends, unlike the workers' kept frames
// (frame_handoff.h), which are keyed by content: a lookup there reads and hashes the
// file again, and what it holds stays for the session's jobs.
constexpr size_t kDerivationFramesBytes = size_t(256) << 20;

class DerivationFrames {
 public:
  // `hash`: keep each file's SHA-256 as it is read.
  explicit DerivationFrames(bool hash) : hash_(hash) {}

  // The file decoded unchanged (io::ImageMode::kUnchanged), errors naming the file.
  cv::Mat Read(const std::filesystem::path& path) {
    const std::string key = path.string();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const auto it = images_.find(key);
      if (it != images_.end()) return it->second;
    }
    const std::string bytes = io::ReadFileBytes(path);
    const cv::Mat image = io::DecodeImage(bytes, io::ImageMode::kUnchanged, key);
    const std::string sha = hash_ ? net::Sha256Hex(bytes) : std::string();
    std::lock_guard<std::mutex> lock(mutex_);
    if (!sha.empty()) shas_.emplace(key, sha);
    const size_t size = image.total() * image.elemSize();
    if (held_ + size <= kDerivationFramesBytes && images_.emplace(key, image).second) held_ += size;
    return image;
  }
  // The SHA-256 of the file's bytes, read again only when Read did not keep it.
  std::string Sha(const std::filesystem::path& path) {
    const std::string key = path.string();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const auto it = shas_.find(key);
      if (it != shas_.end()) return it->second;
    }
    std::string sha = net::Sha256Hex(io::ReadFileBytes(path));
    std::lock_guard<std::mutex> lock(mutex_);
    shas_.emplace(key, sha);
    return sha;
  }
  // The images held (path -> image).
  std::map<std::string, cv::Mat> Held() {
    std::lock_guard<std::mutex> lock(mutex_);
    return images_;
  }
  void Clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    images_.clear();
    held_ = 0;
  }

 private:
  const bool hash_;
  std::mutex mutex_;
  std::map<std::string, cv::Mat> images_;
  std::map<std::string, std::string> shas_;
  size_t held_ = 0;  // bytes of images_' pixels
};

struct GreyStats {
  double median = 0, p99 = 0;
  std::map<std::string, cv::Mat> frames;  // frame path -> image, for the scene's extent
};

// Median and 99th percentile of the valid greys (alpha 255 where there is alpha) of
// every camera's frame at `instant`, sampled on a grid of at most ~64k pixels each. The
// frames are read in parallel and kept: the scene's extent looks at them again. With
// `offer`, each is also offered to the in-process workers' jobs (frame_handoff.h).
GreyStats FrameGreys(const take::Take& take, const std::string& instant, int num_threads,
                     bool offer, DerivationFrames* frames) {
  const auto& cams = take.rig.cameras;
  std::vector<cv::Mat> images(cams.size());
  std::vector<std::vector<int64_t>> histograms(cams.size(), std::vector<int64_t>(256, 0));
  core::ParallelFor(0, int64_t(cams.size()), num_threads, [&](int64_t c0, int64_t c1) {
    for (int64_t c = c0; c < c1; ++c) {
      const std::filesystem::path path = take.FramePath(instant, cams[c].model.id);
      const cv::Mat image = stereo::CheckFrame(frames->Read(path), path.string());
      if (offer) OfferDecodedFrame(frames->Sha(path), image);
      images[c] = image;
      cv::Mat grey;
      if (image.channels() == 1) grey = image;
      if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
      if (image.channels() == 4) cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
      const int step = std::max(1, int(std::sqrt(double(image.total()) / 65536.0)));
      for (int y = 0; y < image.rows; y += step) {
        for (int x = 0; x < image.cols; x += step) {
          if (image.channels() == 4 && image.at<cv::Vec4b>(y, x)[3] != 255) continue;
          ++histograms[c][grey.at<uint8_t>(y, x)];
        }
      }
    }
  });
  std::vector<int64_t> histogram(256, 0);
  int64_t total = 0;
  for (const auto& h : histograms) {
    for (int g = 0; g < 256; ++g) histogram[g] += h[g];
  }
  for (int64_t n : histogram) total += n;
  GreyStats s;
  core::Require(total > 0, take.dir.string(), "no valid pixel in the frames of " + instant);
  auto quantile = [&](double q) {
    int64_t seen = 0;
    for (int g = 0; g < 256; ++g) {
      seen += histogram[g];
      if (double(seen) >= q * double(total)) return double(g);
    }
    return 255.0;
  };
  s.median = quantile(0.5);
  s.p99 = quantile(0.99);
  for (size_t c = 0; c < cams.size(); ++c)
    s.frames.emplace(take.FramePath(instant, cams[c].model.id).string(), std::move(images[c]));
  return s;
}

// The session's options, checked and read before its volume is derived. A volume to be
// derived has no dims yet, and FromVolume would size the seed's 6000 mm cube with the
// given voxel and refuse a voxel too fine for that cube, which does not apply here: the
// derived volume's voxel count is checked where it is made (below), naming that volume.
// So a session without dims is checked as a copy given one placeholder voxel a side;
// every other value, the voxel size itself included, is checked as it is.
SessionOptions ResolveBeforeVolume(const runtime::Session& s, bool volume_derived) {
  if (!volume_derived || s.volume().dims_size() > 0) return ResolveSessionOptions(s, "session");
  runtime::Session probe = s;
  for (int a = 0; a < 3; ++a) probe.mutable_volume()->add_dims(1);
  return ResolveSessionOptions(probe, "session");
}

// The box [lo, hi] shrunk to the bounding box of the masks' visual hull at `instants`
// (silhouette/hull.h; cells of 1/96 of the box's longest side, each tested as its
// enclosing ball, so the box holds every point of the hull), grown by `margin` of its
// size on every side and kept within [lo, hi], when the hull is not empty. `instants`
// are at most MaskOptions::median_max_instants of the session's, evenly spread (those a
// median background uses): a bounded derivation whatever the take's length (a mask per
// camera and instant looked at), and every instant of a take that short. Fewer cut the
// scene at the instants not looked at: the paper take's bat at 6 of its 11 instants with
// the scene extent's 3 (bat barrel completeness within 20 mm 0). The margin (the scene
// extent's) covers some motion between the instants looked at, not all: a longer take
// whose scene moves far between them needs --no-volume-masks or --box.
// With `offer`, each mask is also handed to the masks stage's jobs of this process
// (frame_handoff.h), keyed by the content of the files it was made from.
// `made`: the masks of one instant made already (rig order), used instead of making
// them again.
void HullVolume(silhouette::TakeMasks& masks, const std::vector<std::string>& instants,
                const std::pair<std::string, std::vector<cv::Mat>>& made, double margin,
                int carve_votes, int min_views, int num_threads, bool offer,
                DerivationFrames* frames, bool box_from_stereo, Eigen::Vector3d* lo,
                Eigen::Vector3d* hi, Derivation* d) {
  const take::Take& take = masks.take();
  std::vector<geometry::TsaiCamera> cameras;
  for (const auto& rc : take.rig.cameras) cameras.push_back(rc.model);
  silhouette::HullOptions ho;
  ho.num_threads = num_threads;
  ho.carve_votes = carve_votes;
  ho.min_views = min_views;
  ho.ray_block_px = 1;  // only its box is asked for: no ray bounds
  Eigen::Vector3d a = Eigen::Vector3d::Constant(INFINITY), b = -a;
  // The scene's box comes from coarse stereo, which misses what is thin at its reduced
  // resolution: a bat or an arm raised above the rest (the synthetic dome's batter with
  // six cameras lost the top of his bat at one instant; bench/silhouette/sparse_synth.sh).
  // So the hull is also looked for beyond the box, kHullBeyondFraction of it a side, but
  // there only where every camera sees it in its foreground: a ghost of a few far-apart
  // cameras' cones, which the box keeps out, is mostly seen by fewer. (Panoptic, five
  // cameras: the volume reaches 96 mm further along x, where a person had been cut at
  // the box's face; leave-one-out IoU 0.584 against 0.588, as much as a 1 % larger
  // margin alone moves it; README "Silhouettes".)
  // Where coarse stereo found too few points the box is only the view sphere's, a guess
  // (a take run for one of its instants: Panoptic's 00-03-03-24 alone ended 1 m short of
  // the third person): beyond it the hull's own rule holds.
  const int beyond_views = box_from_stereo ? int(cameras.size()) : 0;
  const Eigen::Vector3d beyond = kHullBeyondFraction * (*hi - *lo);
  const Eigen::Vector3d box_lo = *lo, box_hi = *hi;
  Eigen::Vector3d reach_lo = *lo, reach_hi = *hi;
  for (size_t i = 0; i < instants.size(); ++i) {
    spdlog::info("derive: the masks' visual hull at {} ({}/{})", instants[i], i + 1,
                 instants.size());
    std::vector<cv::Mat> m(cameras.size());
    core::ParallelFor(0, int64_t(cameras.size()), num_threads, [&](int64_t c0, int64_t c1) {
      for (int64_t c = c0; c < c1; ++c) {
        const std::string& id = cameras[size_t(c)].id;
        m[size_t(c)] = instants[i] == made.first && size_t(c) < made.second.size()
                           ? made.second[size_t(c)]
                           : masks.Mask(instants[i], id);
        if (!offer) continue;
        std::vector<std::string> shas;
        for (const auto& path : masks.InputPaths(instants[i], id))
          shas.push_back(frames->Sha(path));
        OfferMask(MaskHandoffKey(id, silhouette::MaskSourceName(masks.Source(id)), shas),
                  m[size_t(c)]);
      }
    });
    const silhouette::VisualHull hull(cameras, m, ho);
    Eigen::Vector3d h_lo, h_hi;
    if (hull.BoundingBox(*lo, *hi, kHullCells, &h_lo, &h_hi)) {
      a = a.cwiseMin(h_lo);
      b = b.cwiseMax(h_hi);
    }
    if (hull.BoundingBox(*lo - beyond, *hi + beyond, kHullCells, &h_lo, &h_hi, beyond_views)) {
      a = a.cwiseMin(h_lo);
      b = b.cwiseMax(h_hi);
      reach_lo = reach_lo.cwiseMin(h_lo);
      reach_hi = reach_hi.cwiseMax(h_hi);
    }
  }
  if (!((b - a).minCoeff() > 0)) {
    d->notes.push_back("volume: the masks' visual hull is empty in the scene's box: kept the box");
    return;
  }
  const Eigen::Vector3d grow = margin * (b - a);
  a = (a - grow).cwiseMax(reach_lo);
  b = (b + grow).cwiseMin(reach_hi);
  *lo = a;
  *hi = b;
  const bool past =
      (reach_lo.array() < box_lo.array()).any() || (reach_hi.array() > box_hi.array()).any();
  d->notes.push_back(fmt::format(
      "volume: {} (shrunk to the bounding box of the masks' visual hull at {} instant(s), "
      "cells of 1/{} of the scene's box, +{:.0f} % a side{})",
      Box(a, b), instants.size(), kHullCells, 100 * margin,
      !past              ? ""
      : beyond_views > 0 ? "; past the scene's box where every camera sees it in its foreground"
                         : "; past the view sphere's box"));
}

}  // namespace

Derivation DeriveSession(const DeriveRequest& request, runtime::Session* s) {
  Derivation d;
  // Each step's wall time, at debug: the derivation runs before any job, on the
  // critical path of `dome run`.
  auto since = [last = std::chrono::steady_clock::now()]() mutable {
    const auto now = std::chrono::steady_clock::now();
    const double seconds = std::chrono::duration<double>(now - last).count();
    last = now;
    return seconds;
  };
  core::Require(!s->take().empty(), "session: take", "no take to derive the session from");
  const take::Take take = take::OpenTake(s->take());
  const std::vector<std::string> instants = SessionInstants(*s, take);
  runtime::StereoSettings* st = s->mutable_stereo();
  runtime::Volume* vol = s->mutable_volume();
  // The volume: the given box, the session's, or the scene's.
  const bool has_box = vol->origin_mm_size() > 0 && vol->dims_size() > 0;
  const bool volume_derived = !has_box || request.box.has_value();
  const SessionOptions given = ResolveBeforeVolume(*s, volume_derived);  // bad values fail first

  int64_t pixels = 0;
  for (const auto& rc : take.rig.cameras)
    pixels = std::max<int64_t>(pixels, int64_t(rc.model.width_px) * rc.model.height_px);
  const bool large = pixels >= kLargeImagePx;

  // Greys: from the images' statistics.
  // Declared before the masks, which read through it.
  DerivationFrames frames(request.offer_frames);
  GreyStats greys = FrameGreys(take, instants[instants.size() / 2], request.num_threads,
                               request.offer_frames, &frames);
  spdlog::debug("derive: frames and greys of {} in {:.2f} s", instants[instants.size() / 2], since());
  if (!st->has_normalize_contrast()) {
    // Most of the grey range unused: stretch the 1st..99th percentile to 0..255.
    st->set_normalize_contrast(greys.p99 < 128);
    d.notes.push_back(
        fmt::format("stereo.normalize_contrast: {} (99th percentile grey {:.0f}; "
                    "stretched below 128)",
                    st->normalize_contrast(), greys.p99));
  }
  if (!st->has_sqrt_greys()) {
    // A dark exposure (even its bright end below half the range) is shot-noise limited:
    // the noise variance grows with the signal, and matching square roots levels it. A
    // bright object on a black background is not dark: there the roots would lift the
    // background's noise.
    st->set_sqrt_greys(greys.p99 < 128);
    d.notes.push_back(
        fmt::format("stereo.sqrt_greys: {} (99th percentile grey {:.0f}; on below 128)",
                    st->sqrt_greys(), greys.p99));
  }
  if (large) {
    // Large images: the settings measured best on megapixel frames (README "Robovision").
    if (st->window_sizes_px_size() == 0) st->add_window_sizes_px(11);
    if (!st->has_min_uniqueness()) st->set_min_uniqueness(0.02);
    if (!st->has_max_neighbours()) st->set_max_neighbours(2);
    d.notes.push_back(fmt::format(
        "stereo: {} px per camera (>= {}): window {}, uniqueness {}, {} neighbours", pixels,
        kLargeImagePx, st->window_sizes_px(0), st->min_uniqueness(), st->max_neighbours()));
  }

  // Silhouettes: each use on when masks can be made for the take (given masks, a
  // background plate, or a median over >= 3 instants: silhouette/take_masks.h) and at
  // least two cameras find a foreground in them (a hull needs two views; a static scene
  // has none against its median), off otherwise. Every use only narrows the search and
  // the surface to where the cameras saw the people.
  runtime::SilhouetteSettings* si = s->mutable_silhouettes();
  std::optional<silhouette::TakeMasks> masks;
  std::vector<cv::Mat> middle_masks;  // rig order: the masks' hull needs them again
  if (!si->has_volume() || !si->has_stereo() || !si->has_fusion() || si->volume()) {
    std::string why;
    try {
      masks.emplace(take, silhouette::MaskOptions{});
      masks->SetFrameReader(
          [&frames](const std::filesystem::path& path) { return frames.Read(path); });
      if (request.offer_frames) {
        // Each frame a mask is made from here (every camera's, at the instants the
        // masks' hull looks at) is a stereo job's input: handed to the workers' jobs.
        masks->SetFrameSeen([&frames](const std::filesystem::path& path, const cv::Mat& image) {
          OfferDecodedFrame(frames.Sha(path), image);
        });
      }
      const std::string& middle = instants[instants.size() / 2];
      const auto& cams = take.rig.cameras;
      std::vector<double> fraction(cams.size());
      middle_masks.assign(cams.size(), cv::Mat());
      core::ParallelFor(0, int64_t(cams.size()), request.num_threads, [&](int64_t c0, int64_t c1) {
        for (int64_t c = c0; c < c1; ++c) {
          silhouette::MaskInfo info;
          middle_masks[size_t(c)] = masks->Mask(middle, cams[size_t(c)].model.id, &info);
          fraction[size_t(c)] = info.fraction;
        }
      });
      int with_foreground = 0;
      for (double f : fraction) with_foreground += f >= kMinForegroundFraction;
      if (with_foreground < 2) {
        why = fmt::format("{} camera(s) with a foreground of >= {} of the image at {}",
                          with_foreground, kMinForegroundFraction, middle);
        masks.reset();
      }
    } catch (const core::InputError& e) {
      why = e.what();
      masks.reset();
    }
    spdlog::debug("derive: masks looked at in {:.2f} s", since());
    const bool on = masks.has_value();
    if (!si->has_volume()) si->set_volume(on);
    if (!si->has_stereo()) si->set_stereo(on);
    if (!si->has_fusion()) si->set_fusion(on);
    // A sparse rig: the median camera's nearest other camera is more than
    // kSparseAxisAngleDeg away in axis angle (Panoptic's five HD cameras are 47 to 119
    // degrees apart). Stereo between such views matches little of the surface (a window
    // sees it foreshortened differently in each), so the hull's surface stands in where
    // no range image saw a voxel, and one camera's background carves a point: with five
    // cameras the default two votes keep what four of them see as foreground, many
    // times the people's volume. A dense rig keeps two votes, so that one camera's mask
    // that misses a limb does not remove it, and no stand-in surface, which there puts a
    // surface into the hull's ghost volume where stereo saw nothing (the paper take, 51
    // cameras: accuracy p90 19.5 mm without it, 34.5 mm with it).
    // On a sparse rig a point must also be in the foreground of every camera but one:
    // what only two or three of a few far-apart cameras see, near the edges of their
    // views, two silhouettes place anywhere along two cones (Panoptic, four cameras at a
    // time, bench/silhouette/panoptic_loo.sh: mean IoU 0.397 with two views, 0.448 with
    // three, 0.418 with all four, where one mask's miss removes a part; measured with a
    // first form of the consensus background; with today's, 0.551 with three and 0.526
    // with all four).
    // A dense rig's cameras each see part of the dome: two views, as stereo needs.
    const int cameras = static_cast<int>(take.rig.cameras.size());
    const double axis_deg = stereo::MedianNearestAxisAngleDeg(take.rig);
    const bool sparse = axis_deg > kSparseAxisAngleDeg;
    if (!si->has_hull_surface()) si->set_hull_surface(on && sparse);
    if (!si->has_carve_votes()) si->set_carve_votes(sparse ? 1 : 2);
    if (!si->has_min_views()) si->set_min_views(sparse ? std::max(2, cameras - 1) : 2);
    // Where the hull's surface stands in, it is carved by photo-consistency first
    // (silhouette/photo_hull.h): a few far-apart cameras' hull of several people holds
    // ghost volume where each camera sees a different person, which stereo between such
    // views does not carve. A dense rig's stereo sees the surface; no carving there.
    if (!si->has_photo_carve()) si->set_photo_carve(si->hull_surface());
    std::string sources;
    if (on) {
      std::map<std::string, int> count;
      for (const auto& rc : take.rig.cameras)
        ++count[silhouette::MaskSourceName(masks->Source(rc.model.id))];
      for (const auto& [name, n] : count) sources += fmt::format(" {} {}", n, name);
    }
    d.notes.push_back(fmt::format(
        "silhouettes: volume {}, stereo {}, fusion {}, hull surface {}, photo carving {}, "
        "carve votes {}, min views {} ({}; "
        "the cameras' median nearest axis angle {:.1f} deg, sparse above {:g})",
        si->volume(), si->stereo(), si->fusion(), si->hull_surface(), si->photo_carve(),
        si->carve_votes(), si->min_views(), on ? "masks:" + sources : "no masks: " + why, axis_deg,
        kSparseAxisAngleDeg));
  }

  Eigen::Vector3d lo, hi;
  std::vector<std::pair<double, double>> camera_depth;  // from the scene's points, rig order
  if (has_box && !request.box) {
    const fusion::VolumeGrid& g = given.grid;
    lo = g.origin_mm;
    hi = g.origin_mm + g.voxel_size_mm * Eigen::Vector3d(g.nx, g.ny, g.nz);
  } else if (request.box) {
    lo = request.box->first;
    hi = request.box->second;
    core::Require((hi - lo).minCoeff() > 0, "--box", "needs XMIN < XMAX, YMIN < YMAX, ZMIN < ZMAX");
    d.notes.push_back("volume: " + Box(lo, hi) + " (--box)");
  } else {
    const stereo::TakeStereoOptions so = ResolveBeforeVolume(*s, volume_derived).stereo;
    stereo::SceneExtentOptions eo;
    eo.num_threads = request.num_threads;
    // The frames already read: the greys' instant, and the masks' median instants.
    std::map<std::string, cv::Mat> decoded = frames.Held();
    decoded.insert(greys.frames.begin(), greys.frames.end());
    const stereo::SceneExtent e =
        stereo::EstimateSceneExtent(take, instants, so.stereo, so.cluster, eo, decoded);
    spdlog::debug("derive: the scene's extent in {:.2f} s", since());
    lo = e.min_mm;
    hi = e.max_mm;
    camera_depth = e.camera_depth_mm;
    d.notes.push_back(fmt::format(
        "volume: {} (the cameras' axes meet at [{:.1f} {:.1f} {:.1f}] mm, {:.1f} mm seen by "
        "every camera; {} at {} instant(s), images reduced {}x: {} points agreeing between "
        "cameras, in pieces of occupied cells, +{:.0f} % a side)",
        Box(lo, hi), e.view_centre_mm.x(), e.view_centre_mm.y(), e.view_centre_mm.z(),
        e.view_radius_mm,
        e.from_stereo ? "coarse stereo" : "too few coarse points: the view sphere",
        e.instants.size(), e.reduction, e.points, 100 * eo.margin_fraction));
    if (si->volume() && masks) {
      HullVolume(
          *masks,
          silhouette::MedianInstants(instants, silhouette::MaskOptions{}.median_max_instants),
          {instants[instants.size() / 2], middle_masks}, eo.margin_fraction, si->carve_votes(),
          si->min_views(), request.num_threads, request.offer_frames, &frames, e.from_stereo, &lo,
          &hi, &d);
      spdlog::debug("derive: the masks' hull in {:.2f} s", since());
    }
  }
  greys.frames.clear();  // read once for all; not held through the rest
  frames.Clear();
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const double footprint = stereo::PixelFootprintMm(take.rig, centre);
  double voxel = vol->has_voxel_size_mm() ? vol->voxel_size_mm() : 0.0;
  if (voxel <= 0 || !has_box || request.box) {
    if (!vol->has_voxel_size_mm()) {
      // 1.5 pixel footprints at the scene (a matched depth is good to about +-0.75 px
      // after the sub-level refinement), no finer than the seed's voxel budget allows.
      const double budget = std::cbrt((hi - lo).prod() / kMaxVoxels);
      voxel = std::max(1.5 * footprint, budget);
      vol->set_voxel_size_mm(voxel);
      d.notes.push_back(fmt::format(
          "volume.voxel_size_mm: {:.4g} (1.5 x the pixel footprint at the scene, {:.4g} mm; "
          "budget of {} voxels: {:.4g} mm)",
          voxel, footprint, kMaxVoxels, budget));
    }
    vol->clear_origin_mm();
    vol->clear_dims();
    for (int a = 0; a < 3; ++a) {
      const double n = std::ceil((hi(a) - lo(a)) / voxel);
      core::Require(
          std::isfinite(n) && n <= double(1 << 20), "session: volume.voxel_size_mm",
          fmt::format("{} mm makes {:.0f} voxels along an axis of {}, {:.1f} mm "
                      "across (at most {})",
                      voxel, n,
                      request.box ? "the --box volume" : "the volume derived from the take",
                      hi(a) - lo(a), 1 << 20));
      vol->add_origin_mm(lo(a));
      vol->add_dims(std::max(1, int(n)));
    }
  }
  voxel = vol->voxel_size_mm();

  // Depth range: the box's nearest and farthest corner over all cameras.
  if (!st->has_z_min_mm() || !st->has_z_max_mm()) {
    double z_lo = INFINITY, z_hi = -INFINITY;
    for (const auto& rc : take.rig.cameras) {
      for (int c = 0; c < 8; ++c) {
        const Eigen::Vector3d p(c & 1 ? hi.x() : lo.x(), c & 2 ? hi.y() : lo.y(),
                                c & 4 ? hi.z() : lo.z());
        const double z = rc.model.WorldToCamera(p).z();
        z_lo = std::min(z_lo, z);
        z_hi = std::max(z_hi, z);
      }
    }
    const double z_min = std::max(0.01 * z_hi, z_lo - 2 * voxel), z_max = z_hi + 2 * voxel;
    core::Require(z_max > z_min && z_max > 0, "volume", "is behind every camera");
    if (!st->has_z_min_mm()) st->set_z_min_mm(z_min);
    if (!st->has_z_max_mm()) st->set_z_max_mm(z_max);
    d.notes.push_back(fmt::format(
        "stereo.z_min_mm .. z_max_mm: {:.1f} .. {:.1f} (the volume's corners over all cameras, "
        "+-2 voxels)",
        st->z_min_mm(), st->z_max_mm()));
  }
  // Each camera searches the depths where the coarse pass found the scene in its image.
  if (st->camera_depths_size() == 0 && !camera_depth.empty()) {
    int n = 0;
    for (size_t c = 0; c < camera_depth.size(); ++c) {
      if (!(camera_depth[c].second > camera_depth[c].first)) continue;
      auto* r = st->add_camera_depths();
      r->set_camera(take.rig.cameras[c].model.id);
      r->set_z_min_mm(std::max(camera_depth[c].first, st->z_min_mm()));
      r->set_z_max_mm(std::min(camera_depth[c].second, st->z_max_mm()));
      if (!(r->z_min_mm() < r->z_max_mm())) {
        st->mutable_camera_depths()->RemoveLast();
        continue;
      }
      ++n;
    }
    d.notes.push_back(fmt::format(
        "stereo.camera_depths: {} camera(s), each the depths of the coarse scene points in its "
        "image (0.2..99.8 %, +10 % and two coarse pixels a side)",
        n));
  }
  // Each camera searches the depths of the volume only.
  if (!st->has_coarse_to_fine() && st->clip_min_mm_size() == 0) {
    for (int a = 0; a < 3; ++a) st->add_clip_min_mm(lo(a));
    for (int a = 0; a < 3; ++a) st->add_clip_max_mm(hi(a));
    if (!st->has_clip_pad_mm()) st->set_clip_pad_mm(2 * voxel);
  }
  if (large && !st->has_coarse_to_fine()) {
    auto* c = st->mutable_coarse_to_fine();
    c->set_min_coarse_depths(8);
    c->set_trim_fraction(0.2);
    c->set_coarse_min_uniqueness(0.5);
    c->set_fill_min_neighbours(1);
    d.notes.push_back(
        "stereo.coarse_to_fine: on (large images), each camera clipped to the volume");
  }
  if (st->has_coarse_to_fine() && st->coarse_to_fine().clip_min_mm_size() == 0) {
    auto* c = st->mutable_coarse_to_fine();
    for (int a = 0; a < 3; ++a) c->add_clip_min_mm(lo(a));
    for (int a = 0; a < 3; ++a) c->add_clip_max_mm(hi(a));
    if (!c->has_clip_pad_mm()) c->set_clip_pad_mm(2 * voxel);
  }
  // A sparse rig: some camera has no other within the cluster's axis angle (it matches
  // with cameras far apart, stereo/cluster.h), so its depths come in fragments.
  bool sparse = false;
  {
    const stereo::ClusterOptions co = ResolveSessionOptions(*s, "session").stereo.cluster;
    const double cos_max = std::cos(co.max_axis_angle_deg * M_PI / 180.0);
    for (const auto& a : take.rig.cameras) {
      bool near = false;
      for (const auto& b : take.rig.cameras)
        near |= &a != &b && a.model.rotation.row(2).dot(b.model.rotation.row(2)) >= cos_max;
      sparse |= !near && a.neighbours.empty();
    }
  }
  if (large && sparse && !st->has_speckle_area_px()) {
    d.notes.push_back("stereo.speckle_area_px: none (a sparse rig: fragments are its depths)");
  }
  if (large && !sparse && !st->has_speckle_area_px()) {
    // Wrong matches come as islands; a true surface piece of a megapixel image is larger.
    // The step between two neighbouring pixels' depths on one surface is the pixel
    // footprint times the tangent of the surface's slant from the camera: five
    // footprints keep surfaces up to 79 degrees from facing the camera in one piece. The
    // step is a property of the image sampling, not of the voxel, which the budget may
    // make coarser (Robovision 12_11_32: 0.19 mm voxels, 0.06 mm footprint).
    st->set_speckle_area_px(int(0.015 * double(pixels)));
    const bool step_given = st->has_speckle_step_mm();
    if (!step_given) st->set_speckle_step_mm(5 * footprint);
    d.notes.push_back(
        fmt::format("stereo.speckle_area_px: {} (1.5 % of the image), step {:.3g} mm ({})",
                    st->speckle_area_px(), st->speckle_step_mm(),
                    step_given ? "given" : "five pixel footprints at the scene"));
  }

  // Fusion: truncation and clamp of three voxels (the seed's ramp), one voxel for large
  // images, whose voxel the budget makes coarser than their matches' depth error.
  runtime::FusionSettings* fu = s->mutable_fusion();
  const double trunc = (large ? 1.0 : 3.0) * voxel;
  if (!fu->has_truncation_mm()) fu->set_truncation_mm(trunc);
  if (!fu->has_front_clamp_mm()) fu->set_front_clamp_mm(fu->truncation_mm());
  d.notes.push_back(
      fmt::format("fusion.truncation_mm: {:.4g}, front_clamp_mm {:.4g} (3 voxels; 1 for "
                  "large images)",
                  fu->truncation_mm(), fu->front_clamp_mm()));
  if (large && !s->has_smooth_iterations()) {
    s->set_smooth_iterations(10);
    d.notes.push_back("smooth_iterations: 10 (large images)");
  }
  // Where the hull's surface stands in (a sparse rig with masks) the surface is the
  // people's hulls, a few large parts, one a person; the small parts are pieces of
  // fusion's surface a voxel or two beside them, where stereo's few depths and the hull
  // differ, and fragments of the hull's ghosts, not detail four or five cameras resolve.
  // Every part under 2 % of the largest part's area is a speck, whatever its size and
  // wherever it is: a whole person is many times that share of the largest part
  // (Panoptic's three people, 36-60 %). (Panoptic, five
  // cameras: 51-87 parts an instant with the dense rigs' rule, the other parts, at the
  // two instants where all three people are whole, a median 1.5-1.8 voxels from them
  // and 2-3 % of the area; 9, 4 and 3 parts with this one, the
  // people the largest. Leave-one-out IoU 0.576 against 0.573, 5 % 0.572, 10 % 0.566;
  // README "Clean output".)
  if (si->hull_surface()) {
    std::vector<std::string> set;
    if (!s->has_speck_area_fraction()) {
      s->set_speck_area_fraction(kSparseSpeckAreaFraction);
      set.push_back(fmt::format("speck_area_fraction {:g}", kSparseSpeckAreaFraction));
    }
    if (!s->has_speck_diagonal_voxels()) {
      // No bound on a speck's size: the volume's diagonal holds every part.
      const auto& dims = s->volume().dims();
      double diagonal = 0;
      for (int a = 0; a < dims.size(); ++a) diagonal += double(dims[a]) * dims[a];
      s->set_speck_diagonal_voxels(std::ceil(std::sqrt(diagonal)));
      set.push_back(fmt::format("speck_diagonal_voxels {:g} (the volume's diagonal)",
                                s->speck_diagonal_voxels()));
    }
    if (!s->has_speck_gap_voxels()) {
      s->set_speck_gap_voxels(0);
      set.push_back("speck_gap_voxels 0");
    }
    if (!set.empty()) {
      std::string list;
      for (const auto& item : set) list += (list.empty() ? "" : ", ") + item;
      d.notes.push_back("specks: " + list +
                        " (the hull's surface stands in: every part under 2 % of the largest "
                        "part's area is a speck)");
    }
  }
  // Time-aware fusion (fusion/temporal_carry.h) steadies what stands still. Without
  // fusion masks the still parts (floor, walls, what stands there) are fused, and each
  // instant alone moves them by its own stereo noise: on by default for a take of
  // several instants (paper take without masks: flicker over the still parts 0.42 mm
  // against 1.80, the moving person's accuracy 6.35 mm against 6.37; README "Time-aware
  // fusion"). With them the still parts are free space and only the moving people are
  // fused, where there is nothing to steady and carried evidence costs accuracy (p90
  // 19.43 mm against 18.98): off.
  runtime::TemporalSettings* te = s->mutable_temporal();
  if (!te->has_fusion()) {
    te->set_fusion(instants.size() > 1 && !si->fusion());
    d.notes.push_back(fmt::format(
        "temporal.fusion: {} ({})", te->fusion(),
        instants.size() < 2 ? "one instant"
        : si->fusion()      ? "fusion masks: the still parts are free space"
                            : "several instants without fusion masks: the still parts steadied"));
  }
  for (const auto& n : d.notes) spdlog::info("derived {}", n);
  if (s->temporal().fusion() && si->fusion() && instants.size() > 1) {
    // Allowed, but said: the masks carve the still parts away as free space, so the
    // carried evidence lands on the moving people (paper take: accuracy p90 19.43 mm
    // with it, 18.98 without; README "Time-aware fusion").
    spdlog::warn(
        "temporal.fusion with silhouettes.fusion: the masks leave only what moves, where "
        "carried evidence costs accuracy; --temporal-fusion pays with --no-fusion-masks");
  }
  ResolveSessionOptions(*s, "derived session");  // what was derived must hold
  return d;
}

}  // namespace dome::pipeline
