// Coarse-to-fine multi-baseline stereo (stereo/multi_baseline.h) over image tiles.
//
// The full search range at full resolution costs pixels x levels (the Robovision
// scenes: 1280x1024 px and ~550 levels per camera). Here:
//   1. coarse pass: every image reduced by `coarse_factor` (pixel averages; a coarse
//      pixel is invalid if any of its pixels is) and matched over the whole range with
//      `coarse_window_px`;
//   2. fine pass: the reference image is cut into tiles of `tile_px`; each tile is
//      matched at full resolution with the options given, but only between the least
//      and greatest coarse depth found in and around it (the extreme `trim_fraction`
//      of them dropped on each side: stray coarse matches), widened on both sides by
//      `margin_levels` coarse levels (the coarse depths are good to a fraction of one);
//      tiles with fewer than `min_coarse_depths` coarse depths around them (coarse
//      matches pass `coarse_min_uniqueness`) are left without depth, unless, once the
//      others are matched, the surface found in `fill_min_neighbours` of the 8 tiles
//      around them reaches them: then they search the union of those tiles' bounds. Every
//      image is cut to what the tile can see (the reference: the tile and its window
//      margin; a neighbour: the projections of that rectangle between the tile's depth
//      bounds), so the cost of a tile is its pixels x its own levels. Tiles run in
//      parallel (options.num_threads, one thread per tile); the result does not depend
//      on the thread count.
// Lens distortion is removed and the grey mapping (contrast normalisation, square
// roots; GreyImage) applied once to each whole image before cutting, in ComputeDepth's
// order and with its percentile stretch, so that every tile sees the ideal greys a
// single full-image run would; the coarse pass and the tiles match them with the ideal
// (distortion-free) cameras.
//
// Depths are z along the reference optical axis, mm, as ComputeDepth's. A pixel the
// full-range search would give a depth can be lost when its coarse neighbourhood has
// no depth or a wrong one, and a tile's narrower search can keep a minimum the full
// range would have rejected as not unique.
#pragma once

#include <Eigen/Core>
#include <string>

#include "stereo/multi_baseline.h"
#include "stereo/search_bounds.h"

namespace dome::stereo {

struct CoarseToFineOptions {
  int coarse_factor = 4;        // image reduction of the coarse pass (>= 2)
  int coarse_window_px = 7;     // SSD window side of the coarse pass, coarse pixels (odd)
  int tile_px = 64;             // fine pass tile side, full-resolution pixels
  double margin_levels = 2.0;   // added below and above a tile's coarse depths, coarse levels
  double trim_fraction = 0.02;  // of a tile's coarse depths ignored at each end, [0, 0.5)
  int min_coarse_depths = 1;    // tiles with fewer coarse depths around them are skipped
  // Uniqueness margin of the coarse pass (StereoOptions::min_uniqueness); 0: the fine
  // pass's. A stricter one keeps fewer, surer coarse depths, so tiles search less.
  double coarse_min_uniqueness = 0.0;
  // A tile left without a search (too few coarse depths around it) searches the union
  // of the depth bounds of those of its 8 neighbours whose fine depths reach it, when
  // there are at least this many: the surface usually goes on across a tile's edge, and
  // the coarse pass, at a quarter of the resolution and a strict uniqueness, leaves dim
  // or slanted parts of an object without coarse depths. A neighbour's surface reaches
  // the tile when its depths, specks removed, hold at least tile_px / 8 pixels within
  // tile_px / 8 of the tile. Filled tiles do not fill others. 0..8; 0: no filling.
  int fill_min_neighbours = 0;
  // A clip box, world frame, mm (clip = true): each reference camera searches only the
  // depths of the box, its range clipped to the nearest and farthest box corner (z along
  // its optical axis) widened by clip_pad_mm on each end (ClipDepthRange).
  bool clip = false;
  Eigen::Vector3d clip_min_mm = Eigen::Vector3d::Zero();  // min corner x y z, mm
  Eigen::Vector3d clip_max_mm = Eigen::Vector3d::Zero();  // max corner x y z, mm
  double clip_pad_mm = 2.0;  // added to each end of a clipped range, mm

  // Throws core::InputError naming the field ("coarse_to_fine.tile_px") when out of range.
  void Check() const;
};

// `options`' depth range (z along `camera`'s optical axis, mm) clipped to the nearest and
// farthest corner of c2f's clip box, each widened by clip_pad_mm; unchanged without a
// box. Throws core::InputError naming `where` and the camera when the clipped range is
// empty (the box is behind the camera or outside the range).
void ClipDepthRange(const CoarseToFineOptions& c2f, const geometry::TsaiCamera& camera,
                    const std::string& where, StereoOptions* options);

// The same for any box (world mm, min and max corner) and pad (mm); `field` names the
// box in the error.
void ClipDepthRangeToBox(const Eigen::Vector3d& box_min_mm, const Eigen::Vector3d& box_max_mm,
                         double pad_mm, const geometry::TsaiCamera& camera,
                         const std::string& field, StereoOptions* options);

// Tighter, for a box the camera sees only part of: the depths of the box's points inside
// the image (sampled on a 25^3 grid; widened by half a sample's diagonal and pad_mm).
void ClipDepthRangeToVisibleBox(const Eigen::Vector3d& box_min_mm,
                                const Eigen::Vector3d& box_max_mm, double pad_mm,
                                const geometry::TsaiCamera& camera, const std::string& field,
                                StereoOptions* options);

// The camera of an image reduced by `factor` (pixel (i, j) averaging the factor x factor
// block from (factor i, factor j)): pitch times factor, centre moved to match, size
// rounded down.
geometry::TsaiCamera ReducedCamera(const geometry::TsaiCamera& camera, int factor);

// Block averages of a CV_32FC1 grey (NaN = no data) over factor x factor blocks, the
// size rounded down; a block with any NaN is NaN. The image of ReducedCamera.
cv::Mat ReduceGrey(const cv::Mat& grey, int factor);

// Where the work went, for benchmarks.
struct CoarseToFineStats {
  int coarse_levels = 0;        // levels of the coarse pass
  int tiles = 0;                // tiles of the reference image
  int tiles_matched = 0;        // tiles given a fine search
  int tiles_filled = 0;         // of those, searched over their neighbours' bounds
  double mean_tile_levels = 0;  // levels per matched tile, mean
  double coarse_seconds = 0;    // greys, reduction and the coarse pass, wall
  double fine_seconds = 0;      // every tile, wall
};

// Stereo as ComputeDepth(input, options), coarse to fine (above). result.num_levels is
// the most levels any fine tile searched.
// With `bounds` (stereo/search_bounds.h), each tile's range is also clipped to its
// pixels' bounds, tiles without a searched pixel are skipped, and depths outside a
// pixel's own bounds are cleared (before the speckle removal).
StereoResult ComputeDepthCoarseToFine(const StereoInput& input, const StereoOptions& options,
                                      const CoarseToFineOptions& c2f,
                                      CoarseToFineStats* stats = nullptr,
                                      const SearchBounds* bounds = nullptr);

// The full-range search (ComputeDepth's options) limited by per-pixel bounds: the
// reference cut into tiles of the kernel's side (stereo/cost_kernel.h kKernelTilePx),
// each searching between the least near and greatest far of its searched pixels
// (within the options' range), tiles without one nothing; then every depth outside its
// pixel's bounds is cleared, and the speckles removed. Where at least half of the tiles
// search, they do so in one kernel pass over the whole images, on the options' level
// grid (ComputeDepth with TileDepths); otherwise each tile alone, cut to the rectangle
// of its searched pixels, on its own grid, as the fine pass above (the .cc says why).
// The cost of a tile is its pixels x its own levels, so a search bounded to a
// silhouette's hull costs what the foreground does. Stats: coarse_seconds is the greys'
// preparation, fine_seconds the search; tiles_matched the tiles searched,
// mean_tile_levels their mean level count.
StereoResult ComputeDepthBounded(const StereoInput& input, const StereoOptions& options,
                                 const SearchBounds& bounds, CoarseToFineStats* stats = nullptr);

}  // namespace dome::stereo
