// The SIMD paths of the cost kernel against its scalar path, on cameras that look at
// a textured plane from converging directions (so warped rows cross neighbour rows and
// the contiguous-load, two-row and gather branches all run) with a hole of missing
// data in one neighbour.
#include "stereo/cost_kernel.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/error.h"
#include "stereo/stereo_test_util.h"

namespace dome::stereo {
namespace {

// Camera at world (cx, cy, 0) turned by `yaw_deg` about its y axis and `roll_deg`
// about its optical axis, focal 200 px, 160x120.
geometry::TsaiCamera TurnedCamera(const std::string& id, double cx, double cy, double yaw_deg,
                                  double roll_deg) {
  geometry::TsaiCamera c = testing::PlaneCamera(id, cx, cy);
  const double d2r = M_PI / 180.0;
  c.rotation = (Eigen::AngleAxisd(roll_deg * d2r, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(yaw_deg * d2r, Eigen::Vector3d::UnitY()))
                   .toRotationMatrix();
  c.translation_mm = -c.rotation * Eigen::Vector3d(cx, cy, 0.0);
  return c;
}

struct Scene {
  cv::Mat ref;
  std::vector<cv::Mat> images;  // CV_32F, integer greys, NaN = no data
  KernelInput input;
};

// With `hole`, a hole without data in the first neighbour.
Scene MakeScene(bool hole = true) {
  const cv::Mat texture = testing::MakeTexture(1024, 11);
  const auto ref_cam = TurnedCamera("ref", 0, 0, 0, 0);
  const std::vector<geometry::TsaiCamera> cams = {TurnedCamera("a", 150, 0, -4, 3),
                                                  TurnedCamera("b", -120, 40, 5, -8),
                                                  TurnedCamera("c", 0, -130, 0, 20)};
  Scene s;
  testing::RenderPlane(ref_cam, 1800, texture, 10.0).convertTo(s.ref, CV_32F);
  KernelInput& in = s.input;
  in.width = ref_cam.width_px;
  in.height = ref_cam.height_px;
  in.reference = s.ref.ptr<float>(0);
  in.num_levels = 40;
  in.w_far = 1.0f / 5000;
  in.w_step = (1.0f / 750 - 1.0f / 5000) / 39;
  in.outside_cost = 400.0f;
  in.half_windows = {2, 4};
  s.images.resize(cams.size());
  for (size_t n = 0; n < cams.size(); ++n) {
    testing::RenderPlane(cams[n], 1800, texture, 10.0).convertTo(s.images[n], CV_32F);
    const Eigen::Matrix3d r = cams[n].rotation * ref_cam.rotation.transpose();
    const Eigen::Vector3d t = cams[n].translation_mm - r * ref_cam.translation_mm;
    const Eigen::Matrix3d a = cams[n].K() * r * ref_cam.K().inverse();
    const Eigen::Vector3d b = cams[n].K() * t;
    KernelNeighbour kn;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) kn.a[i][j] = a(i, j);
      kn.b[i] = b(i);
    }
    kn.width = cams[n].width_px;
    kn.height = cams[n].height_px;
    in.neighbours.push_back(kn);
  }
  if (hole) s.images[0](cv::Rect(60, 40, 25, 20)).setTo(std::numeric_limits<float>::quiet_NaN());
  for (size_t n = 0; n < cams.size(); ++n) in.neighbours[n].image = s.images[n].ptr<float>(0);
  return s;
}

// Moves a neighbour's centre by dz along the reference axis, towards the scene: b = K_n t
// loses dz K_n R_n e3 = dz A K_r e3 (the reference sits at the origin unrotated).
void MoveForward(double dz, KernelNeighbour* nb) {
  const Eigen::Vector3d k_e3 = TurnedCamera("ref", 0, 0, 0, 0).K().col(2);
  for (int i = 0; i < 3; ++i) {
    nb->b[i] -= dz * (nb->a[i][0] * k_e3.x() + nb->a[i][1] * k_e3.y() + nb->a[i][2] * k_e3.z());
  }
}

std::vector<KernelOutput> RunKernel(const KernelInput& in, SimdLevel simd, bool prewarp = false,
                                    int num_threads = 2) {
  KernelInput copy = in;
  copy.max_simd = simd;
  copy.prewarp = prewarp;
  std::vector<KernelOutput> outs(in.half_windows.size());
  const size_t n = size_t(in.width) * in.height;
  for (auto& o : outs) {
    o.best_level.assign(n, -1.0f);
    o.offset.assign(n, 0.0f);
    o.curvature.assign(n, 0.0f);
    o.best_cost.assign(n, 0.0f);
    o.second_cost.assign(n, 0.0f);
  }
  RunCostKernel(copy, num_threads, &outs);
  return outs;
}

TEST(CostKernelTest, SimdPathsAgreeWithScalar) {
  const Scene scene = MakeScene();
  const auto scalar = RunKernel(scene.input, SimdLevel::kNone);
  // The scene is recovered: the plane at 1800 mm is level 12.2 of 40.
  const double true_level = (1.0 / 1800 - 1.0 / 5000) / scene.input.w_step;
  int near_truth = 0, interior = 0;
  for (int y = 30; y < 90; ++y) {
    for (int x = 40; x < 120; ++x) {
      const size_t i = size_t(y) * scene.input.width + x;
      ++interior;
      near_truth += std::abs(scalar[1].best_level[i] + scalar[1].offset[i] - true_level) < 0.5;
    }
  }
  EXPECT_GT(near_truth, 0.8 * interior);

  for (SimdLevel simd : {SimdLevel::kAvx2, SimdLevel::kAvx512}) {
    if (CostKernelSimd() < simd) continue;  // this CPU cannot run it
    const auto fast = RunKernel(scene.input, simd);
    for (size_t k = 0; k < fast.size(); ++k) {
      size_t same = 0, total = 0;
      double max_offset_diff = 0.0, max_rel_cost_diff = 0.0;
      for (size_t i = 0; i < fast[k].best_level.size(); ++i) {
        if (scalar[k].best_level[i] < 0) {
          EXPECT_EQ(fast[k].best_level[i], -1.0f);
          continue;
        }
        ++total;
        if (fast[k].best_level[i] != scalar[k].best_level[i]) continue;
        ++same;
        max_offset_diff =
            std::max(max_offset_diff, double(std::abs(fast[k].offset[i] - scalar[k].offset[i])));
        max_rel_cost_diff =
            std::max(max_rel_cost_diff, std::abs(fast[k].best_cost[i] - scalar[k].best_cost[i]) /
                                            (scalar[k].best_cost[i] + 100.0));
      }
      // The neighbours hold integer greys, so the paths differ only by float rounding
      // (reciprocal with a Newton step against a division).
      EXPECT_GT(same, 0.995 * total) << "simd " << int(simd) << " window " << k;
      EXPECT_LT(max_offset_diff, 0.02) << "simd " << int(simd) << " window " << k;
      EXPECT_LT(max_rel_cost_diff, 1e-3) << "simd " << int(simd) << " window " << k;
    }
  }
}

// A thread hands the SSD rows its bands share on to its next band instead of warping
// them again: one thread (every band after the first reuses them) and four (one band
// each, none does) give the same output, bit for bit, on every path.
TEST(CostKernelTest, SharedBandRowsDoNotDependOnTheThreadCount) {
  const Scene scene = MakeScene();
  for (SimdLevel simd : {SimdLevel::kNone, SimdLevel::kAvx2, SimdLevel::kAvx512}) {
    if (CostKernelSimd() < simd) continue;
    for (bool prewarp : {false, true}) {
      const auto one = RunKernel(scene.input, simd, prewarp, 1);
      const auto four = RunKernel(scene.input, simd, prewarp, 4);
      for (size_t k = 0; k < one.size(); ++k) {
        EXPECT_EQ(one[k].best_level, four[k].best_level) << int(simd) << " " << prewarp;
        EXPECT_EQ(one[k].offset, four[k].offset) << int(simd) << " " << prewarp;
        EXPECT_EQ(one[k].second_cost, four[k].second_cost) << int(simd) << " " << prewarp;
      }
    }
  }
}

// Fraction of interior pixels (window inside the image) whose level plus offset is
// within 0.5 of `true_level`, for window k.
double NearTruth(const std::vector<KernelOutput>& out, size_t k, int width, double true_level) {
  int near_truth = 0, interior = 0;
  for (int y = 30; y < 90; ++y) {
    for (int x = 40; x < 120; ++x) {
      const size_t i = size_t(y) * width + x;
      ++interior;
      near_truth += std::abs(out[k].best_level[i] + out[k].offset[i] - true_level) < 0.5;
    }
  }
  return double(near_truth) / interior;
}

// The pre-warped kernel (neighbours resampled once by the homography at infinity, each
// level a scaling of that, matched in fixed point) recovers the plane as well as the
// exact per-pixel warp, at the same levels for almost every pixel (it interpolates the
// neighbours twice, so not bit for bit). Its paths give the same bits (next test), so
// the scalar one stands for all.
void PrewarpMatchesExactWarp(const Scene& scene) {
  const int width = scene.input.width;
  const double true_level = (1.0 / 1800 - 1.0 / 5000) / scene.input.w_step;
  const auto exact = RunKernel(scene.input, SimdLevel::kNone);
  const auto pre_scalar = RunKernel(scene.input, SimdLevel::kNone, true);
  for (size_t k = 0; k < exact.size(); ++k) {
    EXPECT_GT(NearTruth(pre_scalar, k, width, true_level), 0.8) << "window " << k;
    EXPECT_GE(NearTruth(pre_scalar, k, width, true_level),
              NearTruth(exact, k, width, true_level) - 0.02)
        << "window " << k;
    size_t same = 0, total = 0;
    double max_level_diff = 0.0;
    for (size_t i = 0; i < exact[k].best_level.size(); ++i) {
      if (exact[k].best_level[i] < 0) {
        EXPECT_EQ(pre_scalar[k].best_level[i], -1.0f);
        continue;
      }
      const int y = int(i) / width, x = int(i) % width;
      if (y < 30 || y >= 90 || x < 40 || x >= 120) continue;  // every neighbour sees it
      ++total;
      same += pre_scalar[k].best_level[i] == exact[k].best_level[i];
      max_level_diff = std::max(
          max_level_diff, double(std::abs(pre_scalar[k].best_level[i] + pre_scalar[k].offset[i] -
                                          exact[k].best_level[i] - exact[k].offset[i])));
    }
    EXPECT_GT(same, 0.9 * total) << "window " << k;
    EXPECT_LT(max_level_diff, 1.0) << "window " << k;
  }
}

// Scenes with and without a hole: without one, every J row is a run of columns with
// data (Prewarped::ok_lo, ok_hi), which the kernel reads instead of pair_ok.
TEST(CostKernelTest, PrewarpedNeighboursMatchTheExactWarp) {
  for (const bool hole : {true, false}) {
    SCOPED_TRACE(hole ? "hole" : "no hole");
    PrewarpMatchesExactWarp(MakeScene(hole));
  }
}

// Elements of a and b whose bits differ.
size_t BitDifferences(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size()) return std::max(a.size(), b.size());
  size_t n = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    n += std::bit_cast<uint32_t>(a[i]) != std::bit_cast<uint32_t>(b[i]);
  }
  return n;
}

// The pre-warped kernel is integer arithmetic up to one float conversion and one fused
// multiply-add per pixel, so its scalar, AVX2 and AVX-512 paths give the same bits, and
// workers with different CPUs the same depths. Scenes: a neighbour with a hole (the rows
// with holes take the masked branch); no holes and a width that is not a multiple of
// 32 (every row a run, a partial last block); a neighbour 450 mm nearer the scene,
// which magnifies up to 2.5x at the near levels, so that blocks too wide for the SIMD
// loads take the per-position fallback. The pre-warp itself (FillPrewarp) gathers its
// bicubic taps with AVX-512 or lane by lane by the same max_simd, so this compares
// those too.
TEST(CostKernelTest, PrewarpedPathsGiveTheSameBits) {
  struct Case {
    const char* name;
    Scene scene;
  };
  std::vector<Case> cases;
  cases.push_back({"hole", MakeScene()});
  cases.push_back({"no hole, 150 px", MakeScene(false)});
  {
    Scene& s = cases.back().scene;
    s.ref = s.ref(cv::Rect(0, 0, 150, s.ref.rows)).clone();
    s.input.width = 150;
    s.input.reference = s.ref.ptr<float>(0);
  }
  cases.push_back({"near neighbour", MakeScene()});
  MoveForward(450.0, &cases.back().scene.input.neighbours[1]);
  for (const Case& c : cases) {
    const KernelInput& in = c.scene.input;
    const auto scalar = RunKernel(in, SimdLevel::kNone, true);
    // The pre-warp ran (it differs from the exact warp).
    const auto exact = RunKernel(in, SimdLevel::kNone);
    EXPECT_GT(BitDifferences(scalar[0].best_cost, exact[0].best_cost), 0u) << c.name;
    for (SimdLevel simd : {SimdLevel::kAvx2, SimdLevel::kAvx512}) {
      if (CostKernelSimd() < simd) continue;  // this CPU cannot run it
      const auto fast = RunKernel(in, simd, true);
      for (size_t k = 0; k < fast.size(); ++k) {
        const std::string at = std::string(c.name) + ", simd " + std::to_string(int(simd)) +
                               ", window " + std::to_string(k);
        EXPECT_EQ(BitDifferences(fast[k].best_level, scalar[k].best_level), 0u) << at;
        EXPECT_EQ(BitDifferences(fast[k].best_cost, scalar[k].best_cost), 0u) << at;
        EXPECT_EQ(BitDifferences(fast[k].second_cost, scalar[k].second_cost), 0u) << at;
        EXPECT_EQ(BitDifferences(fast[k].curvature, scalar[k].curvature), 0u) << at;
        EXPECT_EQ(BitDifferences(fast[k].offset, scalar[k].offset), 0u) << at;
      }
    }
  }
}

// Levels per tile (KernelInput::tile_lo / tile_hi): with every tile over every level the
// output is the plain kernel's, bit for bit; with fewer, a pixel whose least cost lies
// inside its tile's levels (not at either end) keeps its level, costs, curvature and
// offset to the bit, its second best can only grow, and a tile without levels gets
// none. The paths (scalar, AVX2, AVX-512; pre-warped and exact) give the same bits as
// each other, as without tiles.
TEST(CostKernelTest, TileLevelsSearchOnlyTheirLevels) {
  const Scene scene = MakeScene();
  const KernelInput& in = scene.input;
  const int tiles_x = (in.width + kKernelTilePx - 1) / kKernelTilePx;
  const int tiles = tiles_x * ((in.height + kKernelTilePx - 1) / kKernelTilePx);
  for (bool prewarp : {true, false}) {
    const auto plain = RunKernel(in, SimdLevel::kNone, prewarp);
    KernelInput all = in;
    all.tile_lo.assign(size_t(tiles), 0);
    all.tile_hi.assign(size_t(tiles), in.num_levels - 1);
    const auto every = RunKernel(all, SimdLevel::kNone, prewarp);
    KernelInput some = in;  // the plane is at level 12.2
    for (int t = 0; t < tiles; ++t) {
      some.tile_lo.push_back(t == 7 ? 1 : 4 + t % 3);
      some.tile_hi.push_back(t == 7 ? 0 : 21 - t % 2);
    }
    const auto scalar = RunKernel(some, SimdLevel::kNone, prewarp);
    for (size_t k = 0; k < plain.size(); ++k) {
      const std::string at = std::string(prewarp ? "pre-warped" : "exact") + ", window " +
                             std::to_string(k);
      EXPECT_EQ(BitDifferences(every[k].best_level, plain[k].best_level), 0u) << at;
      EXPECT_EQ(BitDifferences(every[k].best_cost, plain[k].best_cost), 0u) << at;
      EXPECT_EQ(BitDifferences(every[k].second_cost, plain[k].second_cost), 0u) << at;
      EXPECT_EQ(BitDifferences(every[k].curvature, plain[k].curvature), 0u) << at;
      EXPECT_EQ(BitDifferences(every[k].offset, plain[k].offset), 0u) << at;
      int inside = 0;
      for (int y = 0; y < in.height; ++y) {
        for (int x = 0; x < in.width; ++x) {
          const size_t i = size_t(y) * in.width + x;
          const int t = (y / kKernelTilePx) * tiles_x + x / kKernelTilePx;
          if (t == 7) {
            ASSERT_EQ(scalar[k].best_level[i], -1.0f) << at;
            continue;
          }
          const float l = plain[k].best_level[i];
          if (!(l > some.tile_lo[t] && l < some.tile_hi[t])) continue;
          ++inside;
          ASSERT_EQ(scalar[k].best_level[i], l) << at << " (" << x << ", " << y << ")";
          ASSERT_EQ(scalar[k].best_cost[i], plain[k].best_cost[i]) << at;
          ASSERT_EQ(scalar[k].curvature[i], plain[k].curvature[i]) << at;
          ASSERT_EQ(scalar[k].offset[i], plain[k].offset[i]) << at;
          ASSERT_GE(scalar[k].second_cost[i], plain[k].second_cost[i]) << at;
        }
      }
      EXPECT_GT(inside, in.width * in.height / 2) << at;
      // The exact warp's SIMD paths agree with its scalar one only up to the rounding of
      // the greys (SimdPathsAgreeWithScalar); the pre-warped ones to the bit.
      for (SimdLevel simd : {SimdLevel::kAvx2, SimdLevel::kAvx512}) {
        if (!prewarp || CostKernelSimd() < simd) continue;  // or this CPU cannot run it
        const auto fast = RunKernel(some, simd, prewarp);
        const std::string at_simd = at + ", simd " + std::to_string(int(simd));
        EXPECT_EQ(BitDifferences(fast[k].best_level, scalar[k].best_level), 0u) << at_simd;
        EXPECT_EQ(BitDifferences(fast[k].best_cost, scalar[k].best_cost), 0u) << at_simd;
        EXPECT_EQ(BitDifferences(fast[k].second_cost, scalar[k].second_cost), 0u) << at_simd;
        EXPECT_EQ(BitDifferences(fast[k].curvature, scalar[k].curvature), 0u) << at_simd;
        EXPECT_EQ(BitDifferences(fast[k].offset, scalar[k].offset), 0u) << at_simd;
      }
    }
  }
  KernelInput bad = in;
  bad.tile_lo.assign(size_t(tiles), 0);
  bad.tile_hi.assign(size_t(tiles), in.num_levels);
  std::vector<KernelOutput> outs(in.half_windows.size());
  try {
    RunCostKernel(bad, 1, &outs);
    ADD_FAILURE() << "levels past the last were taken";
  } catch (const core::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("tile levels"), std::string::npos) << e.what();
  }
}

// Where a neighbour's geometry does not suit the pre-warp (it would magnify more than
// 4x: here a neighbour moved 1.5 m forward along the reference axis sees the near
// planes from behind), the kernel runs the exact warp instead: the same output.
TEST(CostKernelTest, PrewarpFallsBackToTheExactWarp) {
  Scene scene = MakeScene();
  MoveForward(1500.0, &scene.input.neighbours[1]);
  for (SimdLevel simd : {SimdLevel::kNone, CostKernelSimd()}) {
    const auto exact = RunKernel(scene.input, simd);
    const auto pre = RunKernel(scene.input, simd, true);
    for (size_t k = 0; k < exact.size(); ++k) {
      EXPECT_EQ(pre[k].best_level, exact[k].best_level) << "window " << k;
      EXPECT_EQ(pre[k].best_cost, exact[k].best_cost) << "window " << k;
    }
  }
}

}  // namespace
}  // namespace dome::stereo
