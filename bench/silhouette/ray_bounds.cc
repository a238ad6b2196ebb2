// silhouette_ray_bounds: the cost of stereo's per-pixel search bounds from the visual hull
// (silhouette/hull.h VisualHull::RayBounds), blocks of rays tested first (the default
// ray_block_px and ray_leaf_px) against every pixel's ray alone (ray_block_px 1), side by
// side in one process, with a check that the blocks' bounds hold every pixel's own (the
// same bounds with --leaf 1), and how much wider they are.
//
//   silhouette_ray_bounds TAKE [--instant HH-MM-SS-FF] [--z-min MM] [--z-max MM]
//                         [--samples N] [--repeats N] [--block PX] [--leaf PX]
//                         [--compare 0|1]
//
// Masks come from the take (silhouette/take_masks.h: given > plate > median). For every
// camera, RayBounds over [z-min, z-max] (default 500..6000 mm) with --samples depth
// samples (default 0: one pixel of parallax per step); each variant timed --repeats
// times (default 3), alternating, one thread; prints per-variant medians of the whole
// rig's seconds and their ratio, plus the hull's construction seconds. --compare 0 times
// the blocks alone (the per-pixel scan takes about ten times as long).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "core/error.h"
#include "silhouette/hull.h"
#include "silhouette/take_masks.h"
#include "take/take.h"

namespace {

using namespace dome;

double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

int Run(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr,
                 "usage: silhouette_ray_bounds TAKE [--instant I] [--z-min MM] [--z-max MM] "
                 "[--samples N] [--repeats N] [--block PX] [--leaf PX] [--compare 0|1]\n");
    return 2;
  }
  std::string instant;
  double z_min = 500, z_max = 6000;
  int samples = 0, repeats = 3, block = silhouette::HullOptions{}.ray_block_px;
  int leaf = silhouette::HullOptions{}.ray_leaf_px;
  bool compare = true;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--instant") instant = v;
    else if (a == "--z-min") z_min = std::stod(v);
    else if (a == "--z-max") z_max = std::stod(v);
    else if (a == "--samples") samples = std::stoi(v);
    else if (a == "--repeats") repeats = std::stoi(v);
    else if (a == "--block") block = std::stoi(v);
    else if (a == "--leaf") leaf = std::stoi(v);
    else if (a == "--compare") compare = std::stoi(v) != 0;
    else throw core::InputError(a, "unknown option");
  }
  const take::Take take = take::OpenTake(argv[1]);
  if (instant.empty()) instant = take.instants.at(take.instants.size() / 2);
  silhouette::TakeMasks take_masks(take, silhouette::MaskOptions{});
  std::vector<geometry::TsaiCamera> cameras;
  std::vector<cv::Mat> masks;
  for (const auto& rc : take.rig.cameras) {
    cameras.push_back(rc.model);
    masks.push_back(take_masks.Mask(instant, rc.model.id));
  }
  silhouette::HullOptions plain;
  plain.distances = false;
  plain.num_threads = 1;
  plain.ray_block_px = 1;
  silhouette::HullOptions blocks = plain;
  blocks.ray_block_px = block;
  blocks.ray_leaf_px = leaf;
  auto t0 = std::chrono::steady_clock::now();
  const silhouette::VisualHull exact(cameras, masks, plain);
  const double build_plain = Seconds(t0);
  t0 = std::chrono::steady_clock::now();
  const silhouette::VisualHull fast(cameras, masks, blocks);
  const double build_blocks = Seconds(t0);
  std::vector<double> ta, tb;
  int64_t differ = 0, searched = 0, not_held = 0, extra = 0;
  // FNV-1a over every camera's block bounds (first repeat): two builds of RayBounds
  // that must agree print the same digest.
  uint64_t digest = 1469598103934665603ull;
  double width = 0, block_width = 0;
  for (int r = 0; r < repeats; ++r) {
    double a = 0, b = 0;
    for (int c = 0; c < int(cameras.size()); ++c) {
      t0 = std::chrono::steady_clock::now();
      const cv::Mat x = compare ? exact.RayBounds(c, z_min, z_max, samples) : cv::Mat();
      a += Seconds(t0);
      t0 = std::chrono::steady_clock::now();
      const cv::Mat y = fast.RayBounds(c, z_min, z_max, samples);
      b += Seconds(t0);
      if (r > 0) continue;
      for (int i = 0; i < y.rows; ++i) {
        const auto* bytes = y.ptr<unsigned char>(i);
        for (size_t k = 0; k < y.cols * y.elemSize(); ++k) digest = (digest ^ bytes[k]) * 1099511628211ull;
      }
      if (!compare) continue;
      for (int i = 0; i < x.rows; ++i) {
        for (int j = 0; j < x.cols; ++j) {
          const cv::Vec2f p = x.at<cv::Vec2f>(i, j), q = y.at<cv::Vec2f>(i, j);
          const bool own = p[0] < p[1], in_block = q[0] < q[1];
          searched += own;
          differ += p[0] != q[0] || p[1] != q[1];
          extra += in_block && !own;
          if (!own) continue;
          not_held += !(in_block && q[0] <= p[0] && q[1] >= p[1]);
          width += p[1] - p[0];
          block_width += q[1] - q[0];
        }
      }
    }
    ta.push_back(a);
    tb.push_back(b);
  }
  std::printf("take %s instant %s: %zu cameras, %lld pixels searched, %lld differ, %lld not "
              "held by the blocks' bounds, %lld more searched, widths %.3fx (leaf %d px)\n",
              argv[1], instant.c_str(), cameras.size(), static_cast<long long>(searched),
              static_cast<long long>(differ), static_cast<long long>(not_held),
              static_cast<long long>(extra), width > 0 ? block_width / width : 0.0, leaf);
  std::printf("blocks' bounds digest %016llx\n", static_cast<unsigned long long>(digest));
  std::printf("hull build s: per pixel %.4f, blocks %.4f\n", build_plain, build_blocks);
  std::printf("RayBounds s (all cameras, median of %d): per pixel %.4f, blocks of %d px %.4f, "
              "ratio %.2fx\n",
              repeats, Median(ta), block, Median(tb), Median(ta) / Median(tb));
  return not_held == 0 && (leaf > 1 || differ == 0) ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "silhouette_ray_bounds: %s\n", e.what());
    return 1;
  }
}
