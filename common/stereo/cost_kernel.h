// The SSSD cost kernel of multi-baseline stereo (internal to dome_stereo; the
// interface is multi_baseline.h, which validates everything before calling it).
//
// Work is cut into bands of reference rows (kKernelTilePx); each thread takes contiguous
// bands, and the SSD rows two bands share (the window's overlap) are computed once per
// thread and handed on per level. With levels per tile (KernelInput::tile_lo) a band
// runs only its tiles' levels, each over the columns of the tiles that have it, and
// bands go one at a time to the next free thread, each computing its own shared rows.
// Per band and per level, for every neighbour the homography is evaluated
// incrementally along each row (q = q0 + x dq, one reciprocal per pixel), the neighbour
// sampled bilinearly and the squared difference added to a band-sized SSD buffer; the
// window sums come from a running vertical sum and a short horizontal sum (both
// vectorized across x). The cost volume is never stored: per pixel the kernel
// keeps the running minimum, the costs at the levels either side of it and the least
// cost outside them (exact, see UpdateRowN in cost_kernel.cc), updated four levels at a
// time, so memory is O(band x width), not O(levels).
//
// With KernelInput::prewarp the neighbours are first resampled by the homography at
// infinity (bicubic); each level is then a scaling of that image, which a row reads
// with one precomputed column pattern (cost_kernel.cc, "Pre-warped neighbours"). It
// works in 16-bit fixed point (greys x 32) and sums the squared differences of two
// neighbours per multiply-add, with AVX-512 (32 pixels per instruction), AVX2 (16) or
// scalar code: the three give the same bits (tests/stereo/cost_kernel_test.cc), so the
// depths do not depend on the worker's CPU.
//
// Where the CPU has AVX-512 (F, BW) or AVX2 and FMA (checked at run time) the exact warp
// runs sixteen or eight pixels at a time on a packed copy of each neighbour: one
// 32-bit word per pixel holds its 2x2 bilinear quad as 8-bit greys (255 = no data),
// so one gather gives a pixel's four taps and their validity. Otherwise (or with
// max_simd = kNone) a scalar path on the float images runs; the paths agree up to
// the rounding of the neighbour greys to integers (tests/stereo/cost_kernel_test.cc).
#pragma once

#include <cstdint>
#include <vector>

namespace dome::stereo {

// Instruction sets of the warp, in increasing order.
enum class SimdLevel { kNone = 0, kAvx2 = 1, kAvx512 = 2 };

// The side of the kernel's tiles, reference pixels: its bands are this many rows, and
// KernelInput::tile_lo / tile_hi give levels per tile of this side.
constexpr int kKernelTilePx = 32;

struct KernelNeighbour {
  double a[3][3];  // x_n ~ a x_r + w b  (ideal pixels, w = 1/z in 1/mm)
  double b[3];
  const float* image = nullptr;  // ideal grey image, row-major, NaN = invalid
  int width = 0;
  int height = 0;
};

struct KernelInput {
  int width = 0, height = 0;
  const float* reference = nullptr;  // ideal grey, row-major, invalid pixels = 0
  int num_levels = 0;
  float w_far = 0.0f;         // inverse depth of level 0, 1/mm
  float w_step = 0.0f;        // inverse depth per level, 1/mm
  float outside_cost = 0.0f;  // squared difference of a sample without data
  std::vector<KernelNeighbour> neighbours;
  std::vector<int> half_windows;            // one per window size
  SimdLevel max_simd = SimdLevel::kAvx512;  // the best path the CPU has, up to this one
  // Resample each neighbour once by the homography at infinity and warp that per level
  // (cost_kernel.cc, "Pre-warped neighbours"): much faster, but a second bilinear
  // interpolation. Falls back to the exact warp where a neighbour's geometry does not
  // suit it, with more than 32 neighbours, an outside cost above 255^2 (the fixed point
  // sums) or a width of 2^15 - 32 pixels or more (16-bit pixel columns). Runs the best of
  // its AVX-512, AVX2 and scalar paths up to max_simd, all with the same output.
  bool prewarp = false;
  // Optional per-tile level ranges: the reference cut into tiles of kKernelTilePx (row
  // major, ceil(width / 32) x ceil(height / 32)); a pixel's costs are those of its
  // tile's levels tile_lo..tile_hi only (lo > hi: none, the pixel gets best_level -1),
  // as if the levels outside did not exist, and its minimum, neighbours' costs and
  // second best are taken over those levels. The work of a band of tiles is the levels
  // of its tiles, each over the columns of the tiles that have it (and their window
  // margin): a search bounded per tile (a silhouette's hull, the previous instant's
  // depths) costs what it searches, in one pass over the image. Empty: every level
  // everywhere.
  std::vector<int> tile_lo, tile_hi;
};

// Per pixel (row-major), per window size. Pixels whose window leaves the image get
// best_level -1.
struct KernelOutput {
  std::vector<float> best_level;   // level of the least cost
  std::vector<float> offset;       // parabola vertex offset in levels, [-0.5, 0.5]
  std::vector<float> curvature;    // c(l-1) - 2 c(l) + c(l+1), summed costs
  std::vector<float> best_cost;    // c(l)
  std::vector<float> second_cost;  // least c outside l-1..l+1
};

// The best path this CPU runs (AVX-512 needs F and BW; AVX2 needs FMA too), at most
// the environment's DOME_MAX_SIMD (avx512, avx2 or scalar) where it is set; another
// value throws core::InputError naming DOME_MAX_SIMD. Read once per process.
SimdLevel CostKernelSimd();

// `outputs` has one entry per half window, each vector sized width x height.
void RunCostKernel(const KernelInput& input, int num_threads, std::vector<KernelOutput>* outputs);

}  // namespace dome::stereo
