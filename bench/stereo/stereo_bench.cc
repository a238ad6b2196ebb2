// Multi-baseline stereo speed against OpenCV's block matcher, side by side (issue 6).
//
//   build-stereo/bin/bench_stereo                      # built-in paper-scale scene
//   DOME_STEREO_BENCH_TAKE=/tmp/paper build-stereo/bin/bench_stereo   # a take's c00
//
// Paper workload (seed §4.3): a 320x245 reference, ~200 levels from the geometry,
// 6 neighbours, 2 threads. Rates:
//   MultiBaseline: evals/s = pixels x levels x neighbours per second (each evaluation
//                  is a warped, bilinear sample of a neighbour and a squared difference,
//                  plus its share of the window sums and the minimum search); the
//                  default options (neighbours pre-warped), and ExactWarp with the
//                  per-pixel homography warp;
//   StereoBM/SGBM: evals/s = pixels x disparities per second (no warping).
// evals/cpu_s divides by the CPU time of the whole process (all threads): the figure to
// compare on a shared, loaded machine, as ratios of runs interleaved in one process:
//   bench_stereo --benchmark_filter='BM_MultiBaseline/7|BM_OpenCvStereoBM/7'
//     --benchmark_min_time=0.5 --benchmark_repetitions=8
//     --benchmark_enable_random_interleaving=true --benchmark_format=json
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <ctime>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <string>

#include "stereo/multi_baseline.h"
#include "stereo/stereo_test_util.h"
#include "stereo/take_stereo.h"
#include "take/crop.h"
#include "take/take.h"

namespace {

using dome::stereo::StereoInput;
using dome::stereo::StereoOptions;

constexpr int kWidth = 320, kHeight = 245;
constexpr int kThreads = 2;

// Ref at the origin, 6 neighbours on a 450 mm ring, f = 400 px, a textured plane at 2 m:
// the largest parallax over 750..5000 mm is 400 * 450 * (1/750 - 1/5000) = 204 px, so
// the geometry gives 205 levels.
StereoInput BuiltInInput() {
  const cv::Mat texture = dome::stereo::testing::MakeTexture(1024, 3);
  const double texel_mm = 6.0;
  StereoInput in;
  in.reference.camera = dome::stereo::testing::PlaneCamera("ref", 0, 0, kWidth, kHeight, 400.0);
  in.reference.image =
      dome::stereo::testing::RenderPlane(in.reference.camera, 2000, texture, texel_mm);
  for (int k = 0; k < 6; ++k) {
    dome::stereo::StereoView v;
    const double a = k * M_PI / 3.0;
    v.camera = dome::stereo::testing::PlaneCamera("n" + std::to_string(k), 450 * std::cos(a),
                                                  450 * std::sin(a), kWidth, kHeight, 400.0);
    v.image = dome::stereo::testing::RenderPlane(v.camera, 2000, texture, texel_mm);
    in.neighbours.push_back(v);
  }
  return in;
}

StereoInput BenchInput() {
  if (const char* dir = std::getenv("DOME_STEREO_BENCH_TAKE")) {
    const auto take = dome::take::OpenTake(dir);
    dome::stereo::ClusterOptions cluster;
    return dome::stereo::LoadStereoInput(take, take.instants.front(),
                                         take.rig.cameras.front().model.id, cluster);
  }
  return BuiltInInput();
}

void MultiBaseline(benchmark::State& state, bool exact_warp, int max_simd = 2) {
  static const StereoInput input = BenchInput();
  StereoOptions opt;
  opt.num_threads = kThreads;
  opt.max_simd = max_simd;
  if (exact_warp) opt.prewarp_neighbours = false;
  opt.window_sizes_px = {int(state.range(0))};
  int levels = 0;
  double match_s = 0;
  const std::clock_t cpu0 = std::clock();
  for (auto _ : state) {
    const auto r = dome::stereo::ComputeDepth(input, opt);
    levels = r.num_levels;
    match_s += r.match_seconds;
    benchmark::DoNotOptimize(r.range_images.front().depth_mm.data);
  }
  const double pixels = double(input.reference.camera.width_px) * input.reference.camera.height_px;
  const double evals = pixels * levels * double(input.neighbours.size());
  state.counters["levels"] = levels;
  state.counters["neighbours"] = double(input.neighbours.size());
  state.counters["evals/s"] =
      benchmark::Counter(evals, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["match_ms"] = 1e3 * match_s / double(state.iterations());
  // Per CPU-second of the whole process (all threads): meaningful on a loaded machine.
  const double cpu_s = double(std::clock() - cpu0) / CLOCKS_PER_SEC;
  state.counters["evals/cpu_s"] = evals * double(state.iterations()) / cpu_s;
}
// The default options: neighbours pre-warped (StereoOptions::prewarp_neighbours).
void BM_MultiBaseline(benchmark::State& state) { MultiBaseline(state, false); }
// The exact per-pixel warp (prewarp_neighbours false, `dome stereo --exact-warp`).
void BM_MultiBaselineExactWarp(benchmark::State& state) { MultiBaseline(state, true); }
BENCHMARK(BM_MultiBaseline)->Arg(5)->Arg(7)->Arg(11)->Unit(benchmark::kMillisecond)->UseRealTime();
// The default options on the kernel's AVX2 path (StereoOptions::max_simd 1), on an
// AVX-512 CPU: the same depths; the code around the kernel keeps the build's
// instruction set (-march=native), so this is not an AVX2 machine's figure.
void BM_MultiBaselineAvx2(benchmark::State& state) { MultiBaseline(state, false, 1); }
BENCHMARK(BM_MultiBaselineAvx2)->Arg(7)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_MultiBaselineExactWarp)
    ->Arg(5)
    ->Arg(7)
    ->Arg(11)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// One tile of coarse-to-fine stereo's fine pass as the product runs it on a large image
// (stereo/coarse_to_fine.h; Robovision: 64-pixel tiles matched alone on one thread, each
// a 76x76 crop with its window margin, 2 neighbours, window 11, about 47 levels around
// its coarse depths): the built-in scene's reference cut to the tile at its centre, two
// of its neighbours, depths 1700..3000 mm (48 levels from the geometry). The same rates
// as above: evals/cpu_s against BM_MultiBaseline's shows what the tile's size costs (the
// pre-warp of each neighbour, the per-level and per-row set-up over short rows).
void BM_MultiBaselineTile(benchmark::State& state) {
  static const StereoInput input = [] {
    const StereoInput whole = BuiltInInput();
    const int side = 76;
    const cv::Rect rect((kWidth - side) / 2, (kHeight - side) / 2, side, side);
    StereoInput tile;
    tile.reference = {dome::take::CropCamera(whole.reference.camera, rect),
                      whole.reference.image(rect).clone(),
                      {}};
    tile.neighbours = {whole.neighbours[0], whole.neighbours[1]};
    return tile;
  }();
  StereoOptions opt;
  opt.num_threads = 1;
  opt.window_sizes_px = {int(state.range(0))};
  opt.z_min_mm = 1700;
  opt.z_max_mm = 3000;
  int levels = 0;
  const std::clock_t cpu0 = std::clock();
  for (auto _ : state) {
    const auto r = dome::stereo::ComputeDepth(input, opt);
    levels = r.num_levels;
    benchmark::DoNotOptimize(r.range_images.front().depth_mm.data);
  }
  const double evals = double(input.reference.camera.width_px) * input.reference.camera.height_px *
                       levels * double(input.neighbours.size());
  state.counters["levels"] = levels;
  state.counters["evals/s"] =
      benchmark::Counter(evals, benchmark::Counter::kIsIterationInvariantRate);
  const double cpu_s = double(std::clock() - cpu0) / CLOCKS_PER_SEC;
  state.counters["evals/cpu_s"] = evals * double(state.iterations()) / cpu_s;
}
BENCHMARK(BM_MultiBaselineTile)->Arg(11)->Unit(benchmark::kMicrosecond)->UseRealTime();

void BM_MultiBaselineThreeWindows(benchmark::State& state) {
  static const StereoInput input = BenchInput();
  StereoOptions opt;
  opt.num_threads = kThreads;
  opt.window_sizes_px = {5, 9, 13};
  for (auto _ : state) {
    const auto r = dome::stereo::ComputeDepth(input, opt);
    benchmark::DoNotOptimize(r.range_images.front().depth_mm.data);
  }
}
BENCHMARK(BM_MultiBaselineThreeWindows)->Unit(benchmark::kMillisecond)->UseRealTime();

// OpenCV peers on a 320x245 rectified pair, 208 disparities, 2 threads.
std::pair<cv::Mat, cv::Mat> BuiltInPair() {
  const cv::Mat texture = dome::stereo::testing::MakeTexture(1024, 3);
  const auto left = dome::stereo::testing::PlaneCamera("l", 0, 0, kWidth, kHeight, 400.0);
  const auto right = dome::stereo::testing::PlaneCamera("r", 450, 0, kWidth, kHeight, 400.0);
  return {dome::stereo::testing::RenderPlane(left, 2000, texture, 6.0),
          dome::stereo::testing::RenderPlane(right, 2000, texture, 6.0)};
}

void BM_OpenCvStereoBM(benchmark::State& state) {
  static const auto pair = BuiltInPair();
  cv::setNumThreads(kThreads);
  const int disparities = 208;
  auto bm = cv::StereoBM::create(disparities, int(state.range(0)));
  cv::Mat disp;
  const std::clock_t cpu0 = std::clock();
  for (auto _ : state) {
    bm->compute(pair.first, pair.second, disp);
    benchmark::DoNotOptimize(disp.data);
  }
  state.counters["evals/s"] = benchmark::Counter(double(kWidth) * kHeight * disparities,
                                                 benchmark::Counter::kIsIterationInvariantRate);
  const double cpu_s = double(std::clock() - cpu0) / CLOCKS_PER_SEC;
  state.counters["evals/cpu_s"] =
      double(kWidth) * kHeight * disparities * double(state.iterations()) / cpu_s;
}
BENCHMARK(BM_OpenCvStereoBM)->Arg(5)->Arg(7)->Arg(11)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_OpenCvStereoSGBM(benchmark::State& state) {
  static const auto pair = BuiltInPair();
  cv::setNumThreads(kThreads);
  const int disparities = 208;
  auto sgbm = cv::StereoSGBM::create(0, disparities, 5, 8 * 25, 32 * 25);
  cv::Mat disp;
  const std::clock_t cpu0 = std::clock();
  for (auto _ : state) {
    sgbm->compute(pair.first, pair.second, disp);
    benchmark::DoNotOptimize(disp.data);
  }
  state.counters["evals/s"] = benchmark::Counter(double(kWidth) * kHeight * disparities,
                                                 benchmark::Counter::kIsIterationInvariantRate);
  const double cpu_s = double(std::clock() - cpu0) / CLOCKS_PER_SEC;
  state.counters["evals/cpu_s"] =
      double(kWidth) * kHeight * disparities * double(state.iterations()) / cpu_s;
}
BENCHMARK(BM_OpenCvStereoSGBM)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
