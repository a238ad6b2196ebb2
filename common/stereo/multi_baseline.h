// Multi-baseline stereo for non-parallel cameras (seed §2.2 and §4.3; M. Okutomi and
// T. Kanade, "A multiple-baseline stereo", IEEE PAMI 15(4), 1993).
//
// For a reference camera and its cluster of neighbours, depth hypotheses are planes
// z = const in the *reference camera frame* (tsai_camera.h: X right, Y down, Z along the
// optical axis, mm), spaced uniformly in inverse depth w = 1/z between 1/z_max and
// 1/z_min. For hypothesis w every neighbour image is warped into the reference view by
// the plane-induced homography of the ideal (kappa1 = 0) cameras
//
//     x_n ~ K_n R K_r^-1 x_r + w K_n T,   R = R_n R_r^T,  T = t_n - R t_r
//
// (world -> camera poses camera = R world + t, as in tsai_camera.h), which is affine in
// w for each reference pixel. The cost of (pixel, w) is the SSSD: squared grey
// differences summed over the neighbours and over a square window. The depth of a pixel
// is the hypothesis of least cost, refined below a level by a parabola through the
// costs of the neighbouring levels, and converted back to z (mm).
//
// Lens distortion is removed once per image (geometry/undistort.h); all warps then
// use the ideal pinhole cameras. The number of levels follows from the geometry
// (CountDepthLevels): one step moves the projection in the neighbour that sees the
// largest parallax by about `level_step_px` pixels.
//
// Reliability (seed §4.3: "pixels without a reliable minimum are marked invalid"):
// a pixel is given a depth only when
//   * its window lies inside the image and every reference pixel in it is valid,
//   * the minimum is not at the first or last level (a minimum at the end of the search
//     range is not a minimum),
//   * the curvature of the cost at the minimum, per sample (window pixels x neighbours),
//     is at least min_curvature (grey^2 per level^2): the cost is not flat,
//   * the least cost outside levels best-1..best+1 exceeds the best by the factor
//     (1 + min_uniqueness) (plus a small allowance for noise): the minimum is unique,
//   * the reference window's grey standard deviation is at least min_texture_grey.
// The reliability map holds the curvature per sample of valid pixels, 0 elsewhere.
//
// Inputs and outputs are plain values (camera models, images, options, depth maps), so
// a worker can receive them over the wire and call ComputeDepth.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "geometry/tsai_camera.h"
#include "stereo/speckle.h"

namespace dome::stereo {

struct StereoOptions {
  double z_min_mm = 750.0;   // nearest depth searched, along the reference axis, in mm
  double z_max_mm = 5000.0;  // farthest depth searched, in mm
  // Number of depth levels; 0 = from the geometry (CountDepthLevels with level_step_px).
  int num_levels = 0;
  // Parallax per level in the widest-baseline neighbour, in pixels (when num_levels = 0).
  double level_step_px = 1.0;
  // Square SSD window sides, in pixels (odd, 1..31). Each gives its own range image
  // (seed §5: fused separately).
  std::vector<int> window_sizes_px = {7};
  // Stretch each image's grey levels linearly so that its 1st..99th percentile (over
  // valid pixels) spans 0..255 before matching: for dark real images (Robovision) and
  // cameras with different gains.
  bool normalize_contrast = false;
  // Match the square roots of the greys (after the stretch above, when asked for; greys
  // below 0 count as 0), scaled so that 0..255 stays 0..255: 255 sqrt(g / 255). A
  // sensor's shot noise has a variance that grows with the signal; after the square root
  // it is about the same at every grey (the variance-stabilising transform of Poisson
  // counts, as Anscombe's), so that dark and bright parts of a window weigh by what
  // they can tell apart rather than by their brightness. On dim real images (Robovision,
  // README) it gives depth on the shaded parts of the object the linear greys leave
  // without. The black level is taken as grey 0 (or the 1st percentile when stretched).
  bool sqrt_greys = false;
  // Squared-difference cost of a neighbour sample that falls outside the neighbour's
  // image or on its invalid pixels, as a grey difference (cost = value^2), in grey levels.
  double outside_difference_grey = 20.0;
  // Least cost curvature at the minimum, per sample, in grey^2 per level^2.
  double min_curvature = 0.5;
  // Least relative margin of the second-best cost (outside best +-1 level) over the best.
  double min_uniqueness = 0.05;
  // Least grey standard deviation in the reference window, in grey levels.
  double min_texture_grey = 2.0;
  int num_threads = 0;  // 0 = all hardware threads
  // Resample each neighbour once onto the reference grid (by the homography of the
  // plane at infinity, bicubic) so that each depth level is a scaling of that image,
  // matched in 16-bit fixed point (AVX-512, AVX2 or scalar, with the same depths on
  // every CPU): 2x (AVX-512) to 4x (AVX2) faster than the exact per-pixel warp
  // (bench/stereo/stereo_bench.cc), with depths that differ slightly from it (a second,
  // bilinear, interpolation of the neighbour; cost_kernel.h, KernelInput::prewarp).
  // false = the exact warp (`dome stereo --exact-warp`, JSON "prewarp_neighbours": false).
  bool prewarp_neighbours = true;
  // The best instruction set the cost kernel may use: 2 = AVX-512, 1 = AVX2, 0 = scalar
  // (cost_kernel.h SimdLevel); the CPU's best up to it runs. The depths are the same on
  // every path with pre-warped neighbours; lower values are for benchmarks and tests
  // (bench_stereo times the AVX2 path on an AVX-512 CPU).
  int max_simd = 2;
  // Small pieces of each range image removed after matching (stereo/speckle.h); off by
  // default. Coarse-to-fine stereo removes them from the whole image, not per tile.
  SpeckleOptions speckle;

  // Throws core::InputError naming the first option out of range (e.g. "z_min_mm").
  void Check() const;
};

// The options for real photographs ("real" profile of `dome stereo --profile`): the
// defaults with a 50% uniqueness margin (min_uniqueness 0.5) and windows 9 and 13.
// Sensor noise, JPEG blocks and non-Lambertian surfaces leave second minima close to
// the best that the default 5% margin lets through; on Middlebury Aloe this takes the
// bad-pixel rate (> 2 px) of window 13 from 14.5% to 2.8% at 68% density
// (bench/stereo/stereo_accuracy.cc aloe). The defaults stay as they are for the
// synthetic dome, where the stricter margin costs more density than it gains.
StereoOptions RealImageOptions();

// One view: a camera (distorted Tsai model) and its image. `image` is 8-bit gray,
// BGR or BGRA (alpha 255 = valid pixel), or CV_32FC1 grey (NaN = invalid), of the
// camera's width_px x height_px.
struct StereoView {
  geometry::TsaiCamera camera;
  cv::Mat image;
  // Optional: IdealGrey's result for this view and the search's options, made by a
  // caller that keeps it between searches (a worker's stereo jobs share frames); empty:
  // made from `image` when needed. A view cut from another (a crop) has none.
  cv::Mat ideal_grey{};
};

struct StereoInput {
  StereoView reference;
  std::vector<StereoView> neighbours;  // the cluster without the reference (>= 1)
};

struct RangeImage {
  int window_px = 0;
  cv::Mat depth_mm;      // CV_32FC1, z along the reference optical axis in mm, 0 = invalid
  cv::Mat reliability;   // CV_32FC1, cost curvature per sample (grey^2/level^2), 0 = invalid
  double density = 0.0;  // fraction of pixels with a depth
};

struct StereoResult {
  std::string camera;  // the reference camera id
  int num_levels = 0;
  std::vector<RangeImage> range_images;  // one per window size, in the options' order
  double prepare_seconds = 0.0;          // undistortion and conversion
  double match_seconds = 0.0;            // the cost volume and the minimum search
  int64_t tiles_searched = 0;            // with TileDepths: tiles given levels
  int64_t tile_levels = 0;               // ... and their levels, summed

  std::string BriefReport() const;
};

// The level count from the geometry: the largest parallax, in pixels, between the
// projections at z_min and z_max of any of a 9x9 grid of reference pixels into any
// neighbour (ideal pinhole cameras), counting only the part of that epipolar segment
// that falls inside the neighbour's image in front of it (sampled at 256 steps of
// inverse depth), divided by step_px, rounded up, plus one. For a rectified pair with baseline B
// and focal f pixels this is ceil(f B (1/z_min - 1/z_max) / step_px) + 1. Throws InputError when no
// grid point projects into any neighbour.
int CountDepthLevels(const geometry::TsaiCamera& reference,
                     const std::vector<geometry::TsaiCamera>& neighbours, double z_min_mm,
                     double z_max_mm, double step_px);

// Depth of level l of n (0 = z_max, n-1 = z_min), uniform in inverse depth; fractional
// levels allowed.
double LevelDepthMm(double level, int num_levels, double z_min_mm, double z_max_mm);

// Depths searched per tile of the reference (stereo/cost_kernel.h kKernelTilePx square
// tiles, row major, ceil(width / 32) x ceil(height / 32)): near_mm..far_mm, z along the
// reference's axis; near >= far: the tile is not searched.
struct TileDepths {
  std::vector<float> near_mm, far_mm;
};

// Runs the stereo. Throws core::InputError naming the option or view at fault (no
// neighbours, an image of the wrong size or type, a bad camera, bad options).
// With `tiles`, each tile searches the levels of the options' grid (z_min..z_max,
// num_levels or the geometry's count) that cover its depths, plus one either side,
// in one kernel pass (KernelInput::tile_lo); a minimum on a tile's first or last level
// has no curvature and gives no depth.
StereoResult ComputeDepth(const StereoInput& input, const StereoOptions& options,
                          const TileDepths* tiles = nullptr);

// A view's grey as CV_32FC1, NaN where the pixel has no data (alpha below 255, NaN, or
// no source after undistortion); in the ideal camera when `undistort`, else in the
// image's own pixels. Of `options`, only the grey mapping is used: with
// normalize_contrast the 1st..99th percentile of the valid greys is stretched to 0..255
// (dark images), then with sqrt_greys each grey g becomes 255 sqrt(max(g, 0) / 255).
// `where` names the view in errors.
cv::Mat GreyImage(const StereoView& view, const StereoOptions& options, bool undistort,
                  const std::string& where);
// GreyImage(view, options, /*undistort=*/true, where), or view.ideal_grey when it is set
// (checked to be CV_32FC1 of the camera's size; InputError naming `where` otherwise).
cv::Mat IdealGrey(const StereoView& view, const StereoOptions& options, const std::string& where);

}  // namespace dome::stereo
