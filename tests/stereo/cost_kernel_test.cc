// The SIMD paths of the cost kernel against its scalar path, on cameras that look at
// a textured plane from converging directions (so warped rows cross neighbour rows and
// the contiguous-load, two-row and gather branches all run) with a hole of missing
// data in one neighbour.
#include "stereo/cost_kernel.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <cmath>
#include <limits>
#include <vector>

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

Scene MakeScene() {
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
  // A hole without data in the first neighbour.
  s.images[0](cv::Rect(60, 40, 25, 20)).setTo(std::numeric_limits<float>::quiet_NaN());
  for (size_t n = 0; n < cams.size(); ++n) in.neighbours[n].image = s.images[n].ptr<float>(0);
  return s;
}

std::vector<KernelOutput> RunKernel(const KernelInput& in, SimdLevel simd) {
  KernelInput copy = in;
  copy.max_simd = simd;
  std::vector<KernelOutput> outs(in.half_windows.size());
  const size_t n = size_t(in.width) * in.height;
  for (auto& o : outs) {
    o.best_level.assign(n, -1.0f);
    o.offset.assign(n, 0.0f);
    o.curvature.assign(n, 0.0f);
    o.best_cost.assign(n, 0.0f);
    o.second_cost.assign(n, 0.0f);
  }
  RunCostKernel(copy, 2, &outs);
  return outs;
}

TEST(CostKernelTest, SimdPathsAgreeWithScalar) {
  const Scene scene = MakeScene();
  const auto scalar = RunKernel(scene.input, SimdLevel::kNone);
  // The scene is recovered: the plane at 1800 mm is level 23.9 of 40.
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

}  // namespace
}  // namespace dome::stereo
