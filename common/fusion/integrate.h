// Fusion of range images into a slab of voxel planes (seed §3 and §4.4; Curless &
// Levoy, "A volumetric method for building complex models from range images",
// SIGGRAPH 1996), with the seed's change to Curless-Levoy:
//
//  * Forward mapping (seed Figure 6): every voxel centre is projected into every
//    range image with that camera's Tsai model (geometry/tsai_camera.h; pose world ->
//    camera, camera z forward, distorted pixels with (0, 0) at the top-left pixel
//    centre).
//  * Tessellation rule (seed §3): each 2x2 pixel quad is split along its (x, y) ->
//    (x+1, y+1) diagonal into two triangles; a triangle exists only when its three
//    depths are valid (> 0) and differ by at most max_depth_jump_ratio of the nearest
//    one. Depth is interpolated only inside an existing triangle (inverse depth is
//    interpolated linearly in the image, which is exact for the planar 3D triangle
//    through the three back-projected samples), never across a depth jump.
//  * Signed distance along the camera's ray: d = (D - z) * |(x/z, y/z, 1)|, with z the
//    voxel's camera depth and D the interpolated surface depth, both mm; d > 0 in
//    front of the surface (free space).
//  * Free space (seed §3, "we allow the algorithm to adjust all voxels in front of
//    the surface"): every voxel in front of the surface is updated; d is clamped to
//    front_clamp_mm so that one view cannot overwhelm the others. Voxels further than
//    truncation_mm behind the surface are left untouched.
//  * Weights: uniform (the seed: "we eliminated all weights") or a per-pixel
//    reliability map interpolated like the depth.
//  Accumulation (Curless-Levoy): W = sum w_c, D = sum w_c d_c / W. The clamped
//  free-space contributions of uniform weight are counted (n) and the others summed in
//  camera order: W = n + sum' w_c, D = (n * clamp + sum' w_c d_c) / W. The arithmetic of
//  one voxel depends only on its indices, so every slab partition and thread count
//  gives bit-identical values.
//
// Range images: z-depth along the optical axis in mm, 0 = none (io/depth_tiff.h),
// exactly the camera's width_px x height_px.
#pragma once

#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "fusion/volume.h"
#include "geometry/tsai_camera.h"

namespace dome::fusion {

struct FusionOptions {
  // Voxels more than this far behind the observed surface (along the ray) are not
  // updated, in mm. Curless-Levoy's ramp half-width; ~3 voxels.
  double truncation_mm = 60.0;
  // Largest contribution of one view in front of the surface (seed §3), in mm.
  double front_clamp_mm = 60.0;
  // Neighbouring pixels whose depths differ by more than this fraction of the nearer
  // depth are not connected (no interpolation across the jump), dimensionless.
  double max_depth_jump_ratio = 0.05;
  // Voxels closer to a camera than this are not updated by it, in mm (camera z).
  double min_depth_mm = 1.0;
  // Multi-view consistency before fusion (fusion/consistency.h): when > 0, a depth
  // sample is fused only if at least this many other cameras' range images see a
  // surface within consistency_tolerance_mm of it (count; 0 = every sample is fused).
  int min_consistent_views = 0;
  double consistency_tolerance_mm = 20.0;  // depth difference seen from the other camera, mm
  // Voxels whose summed weight (uniform weights: the number of images that updated them)
  // is below this are written as unobserved (weight 0, distance 0), so that marching
  // cubes leaves no surface where fewer images saw one (unitless; 0 = keep every voxel).
  double min_weight = 0.0;
  // Threads over the blocks of a slab; <= 0: all hardware threads.
  int num_threads = 0;
  // Skip work with a conservative test of 32x32x8 super-blocks, then 8^3 blocks, against
  // each camera's frustum and a min/max depth pyramid of its image: (super-)blocks
  // wholly in clamped free space get the clamp counted once instead of sampled per
  // voxel, those wholly far behind the surface or outside the image are skipped; then
  // per voxel, the min/max depth of the 4x4-pixel tile, then of the pixel quad it
  // projects into decides clamped free space or far behind without interpolating. The
  // values are bit-identical with it off (tested).
  bool block_culling = true;

  // Throws core::InputError naming the first option out of range.
  void Check() const;
};

struct RangeImage {
  geometry::TsaiCamera camera;
  cv::Mat depth_mm;   // CV_32FC1, camera.height_px x camera.width_px, 0 = invalid
  cv::Mat weight;     // empty (uniform weight 1) or CV_32FC1 of the same size, >= 0
  std::string where;  // names the source (file) in errors
  // The pixel grid of depth_mm. false: the ideal (undistorted) camera's, as stereo
  // writes them (stereo/multi_baseline.h undistorts every image once and matches in
  // the ideal cameras). true: the real camera's, Tsai's kappa1 included, as the
  // synthetic truth depth maps are rendered (TAKE/truth/<instant>/depth/).
  bool distorted_pixels = false;

  // The camera whose pixels the depth map holds: `camera` without its distortion, or
  // with Tsai's kappa1 when distorted_pixels. Projecting an ideal-pixel map through the
  // distortion would move each voxel by the distortion's displacement (pixels towards
  // the corners) away from the depth that measured it.
  geometry::TsaiCamera PixelCamera() const {
    geometry::TsaiCamera c = camera;
    c.lens = {};
    if (!distorted_pixels) c.kappa1_per_mm2 = 0.0;
    return c;
  }
};

// Throws core::InputError naming the image's `where` when the depth map is not
// CV_32FC1 of its camera's size, holds a NaN, infinite or negative depth, or the weight
// map does not match; and when the camera itself is invalid.
void CheckRangeImage(const RangeImage& image);

// Per-camera data precomputed once per instant (projection tables, frustum); reused
// by every slab of that instant. The tables' memory (about 1.3 MB per 320x245 camera)
// stays with the process when an integrator ends (the largest one freed is kept) and
// is reused by the next one that fits, so that instant after instant do not fault it in.
class Integrator {
 public:
  // Checks `grid`, `options` and every image (above). The images are referenced, not
  // copied: they must outlive the integrator.
  Integrator(const VolumeGrid& grid, const std::vector<RangeImage>& images,
             const FusionOptions& options);
  ~Integrator();
  Integrator(const Integrator&) = delete;
  Integrator& operator=(const Integrator&) = delete;

  // Fuses every image into planes [k0, k1); throws core::InputError when the slab is
  // not inside the volume. Memory: the slab (8 bytes per voxel) plus ~100 KB per thread.
  Slab IntegrateSlab(int k0, int k1) const;
  // The same into `slab`, reusing its buffers (no allocation when the size repeats), on
  // `num_threads` threads (<= 0: the options'); the result is the same on any number.
  void IntegrateSlab(int k0, int k1, Slab* slab, int num_threads = 0) const;

  const VolumeGrid& grid() const { return grid_; }

  struct CameraTables;  // per-camera tables (integrate.cc)
  struct Arena;         // the memory of every camera's tables (integrate.cc)

 private:
  struct Scratch;
  enum class BlockClass { kExact, kSkip, kFreeSpace };
  BlockClass ClassifyBlock(const CameraTables& t, int i0, int i1, int j0, int j1, int k0,
                           int k1) const;
  void IntegrateSuperBlock(int si, int sj, int sk, int k0, int k1, Slab* slab,
                           Scratch* scratch) const;

  VolumeGrid grid_;
  FusionOptions options_;
  std::unique_ptr<Arena> arena_;
  std::vector<CameraTables> cameras_;
};

// The distortion factor lambda(rn^2) = distorted / undistorted radius of a camera, over
// rn^2 in [0, rn2_max] (normalized undistorted coordinates), as the polynomial of degree
// 4 in x = rn^2 / rn2_max the fusion kernel evaluates in float (Horner, fused
// multiply-adds): coefficients c[0] + c[1] x + ..., and its largest error against the
// exact factor over the range. `usable` when that error is below 3e-7 (a thousandth of
// a pixel at 3000 px): the kernel then evaluates it instead of reading a table.
struct DistortionPolynomial {
  float c[5] = {1, 0, 0, 0, 0};
  double max_error = 0;
  bool usable = false;
};
DistortionPolynomial FitDistortionPolynomial(const geometry::TsaiCamera& camera, double rn2_max);

// How the 8-lane (AVX2) kernel reads its per-camera tables: with the CPU's gathers, or
// with scalar loads put together, which some CPUs run much faster. Both read the same
// values, so every result is the same bits. kAuto (the default) times both once per
// process; the others are for tests and benchmarks.
enum class TableLookups { kAuto, kGathers, kLoads };
void SetTableLookups(TableLookups lookups);

// Convenience: fuses the whole volume in slabs of `planes_per_slab`, calling
// `consume(slab)` for each in plane order (memory bounded by one slab).
void FuseVolume(const VolumeGrid& grid, const std::vector<RangeImage>& images,
                const FusionOptions& options, int planes_per_slab,
                const std::function<void(const Slab&)>& consume);

}  // namespace dome::fusion
