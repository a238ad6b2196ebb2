// Search bounds from the previous instant of a take (time-aware stereo). A dome's
// scene is mostly still from one instant to the next: the floor, the walls and whatever
// stands there. Where a reference camera's image is unchanged since the previous
// instant, the surface it sees has not moved farther than its images can hide, so the
// search there needs only the depths the previous instant found, widened by a margin;
// where the image changed or the previous instant found nothing, it searches the whole
// range. The result is intersected with any other bounds (the visual hull's).
//
// Grid, frame and units: the reference camera's ideal (distortion-free) pixel grid,
// where stereo matches and range images are (multi_baseline.h); depths z along its
// optical axis, mm; greys as GreyImage gives them (CV_32FC1, NaN: no data).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "stereo/multi_baseline.h"
#include "stereo/search_bounds.h"

namespace dome::stereo {

struct TemporalBoundsOptions {
  // Square tiles, px of the ideal grid: a tile is judged changed or still as a whole
  // (a pixel's own grey difference is mostly noise). The bounded search
  // (coarse_to_fine.h ComputeDepthBounded) searches tiles of 32 px over the widest range
  // of their pixels: tiles of the same size, aligned, keep a changed tile's whole range
  // from spreading to its still neighbours' search.
  int tile_px = 32;
  // The margin either side of the previous depths, in levels of the search (uniform in
  // inverse depth, multi_baseline.h LevelDepthMm): the parallax a surface may move by
  // along the epipolar lines while its image stays as it was. 8 levels of a 1 px step
  // are 8 px along the widest baseline's epipolar line.
  double margin_levels = 8.0;
  // A tile changed when its mean absolute grey difference between the two instants
  // exceeds change_factor times the median over the image's tiles (the sensor's noise:
  // most of a dome's image is still) plus change_floor_grey (0..255 greys); a rule from
  // the data, so that a noisy camera is not judged changed everywhere.
  double change_factor = 3.0;
  double change_floor_grey = 2.0;
  // The fraction of a tile's previous depths left out at either end of its range (wrong
  // matches); [0, 0.5).
  double outlier_fraction = 0.02;
  // A still tile is bounded only when at least this fraction of its pixels had a depth
  // at the previous instant; otherwise the previous instant knew too little there.
  double min_depth_fraction = 0.25;

  // Throws core::InputError naming the first bad option ("temporal.tile_px").
  void Check() const;
};

struct TemporalBoundsStats {
  int tiles = 0;        // tiles of the grid
  int bounded = 0;      // still, with previous depths: searched around them
  int changed = 0;      // searched whole: the images differ
  int unknown = 0;      // searched whole: too few previous depths
  double threshold_grey = 0.0;  // the change threshold the rule gave
};

// The change rule alone, for any two greys of one image grid (CV_32FC1, NaN: no data):
// per square tile of `tile_px`, 1 where the tile changed -- its mean |now - before| over
// the pixels with both greys exceeds change_factor x the median over the image's tiles
// plus change_floor_grey (greys), or no pixel has both -- and 0 where it is still.
// CV_8UC1 of ceil(rows / tile_px) x ceil(cols / tile_px). *threshold_grey: the
// threshold the rule gave. Throws core::InputError naming `where` when the greys differ
// in size or type.
cv::Mat ChangedTiles(const cv::Mat& grey_before, const cv::Mat& grey_now, int tile_px,
                     double change_factor, double change_floor_grey, const std::string& where,
                     double* threshold_grey = nullptr);

// Per-pixel bounds for the reference camera of this instant from its range images of
// the previous instant (`previous`, every window's, union) and its greys then and now
// (`grey_before`, `grey_now`, the ideal grid). A bounded tile's range is the least to
// greatest previous depth (each tile's outlier_fraction at either end left out) over it
// and its 8 neighbour tiles (a surface edge in one tile
// is often found in the next), widened by margin_levels of a num_levels search over
// [z_min_mm, z_max_mm]; every other tile gets the whole range. Throws core::InputError
// naming `where` when sizes or types differ.
SearchBounds TemporalBounds(const std::vector<RangeImage>& previous, const cv::Mat& grey_before,
                            const cv::Mat& grey_now, double z_min_mm, double z_max_mm,
                            int num_levels, const TemporalBoundsOptions& options,
                            const std::string& where, TemporalBoundsStats* stats = nullptr);

// Per pixel, the part of `outer`'s range that `inner` also allows; where they do not
// overlap (inner was wrong there), `outer`'s own. A pixel `outer` does not search stays
// unsearched. Both of one size.
SearchBounds IntersectBounds(const SearchBounds& outer, const SearchBounds& inner);

}  // namespace dome::stereo
