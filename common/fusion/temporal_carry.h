// Time-aware fusion: a fused slab (fusion/integrate.h) steadied by the previous instant's
// fused slab where the scene did not move.
//
// A dome's scene is mostly still from one instant to the next (the floor, the walls, what
// stands there). Fused on its own, every instant's surface there moves by its own stereo
// noise and wrong matches: the delivered sequence flickers. Where every camera's image
// is unchanged since the previous instant, the voxel's previous evidence still holds, so
// it is added to this instant's, scaled by `decay`:
//   W = W_now + decay W_before,   D = (W_now D_now + decay W_before D_before) / W
// (D the signed distance, mm; W the summed weight). The previous slab is itself the
// steadied one, so a still voxel averages the instants back to the last change, the
// older ones weighted down by decay per instant: noise falls with the square root of
// the instants averaged, and a surface a wrong match made at one instant only is
// outweighed by the instants that saw free space there. A voxel this instant did not
// observe (weight 0) is left unobserved: carried there, the wrong matches of every
// earlier instant pile up where no range image looks again (paper take without masks,
// 11 instants: the last instant's surface had 168 k vertices against 94 k, the new ones
// far from any true surface; observed voxels only: 86 k). Where anything changed, only
// this instant's evidence counts: moving parts follow the images with no lag and leave
// no ghost.
//
// "Unchanged" is judged per cubic block of block_voxels voxels, by the cameras that see
// it (any of its 8 corners in front of the camera, projecting into the image): one of
// them sees a change over the block when a changed tile (stereo/temporal_bounds.h
// ChangedTiles, on that camera's own pixel grid) meets the rectangle the block's
// corners project to (a block across the camera's plane: the whole image). The block
// changed when at least changed_fraction of the cameras that see it see a change. A
// surface that moves into or out of the block changes every view of it that nothing
// hides, so with a dome's many cameras most of them; a person who passes between the
// block and some cameras changes only those views, and the block's still surface
// behind stays steady. A block no camera sees has no evidence from either instant and
// is left as it is.
//
// Frames and units: world mm (the grid's); tiles on each camera's distorted pixel grid
// (TsaiCamera::Project), tile_px square from the image's top-left corner.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "fusion/volume.h"
#include "geometry/tsai_camera.h"

namespace dome::fusion {

struct TemporalCarryOptions {
  // The previous instant's weight factor, (0, 1]: 1 averages every still instant
  // equally; below 1 the older ones count less (an instant n back, decay^n).
  double decay = 1.0;
  // Edge of the blocks judged still or changed, voxels (>= 1).
  int block_voxels = 8;
  // A block changed when at least this fraction of the cameras that see it see a
  // change over it, (0, 1]. Half: a surface moving inside a block changes most of its
  // views; a person in front of a still block, the views from one side of the dome.
  // A quarter left the floor changed wherever the bat's swing crossed a quarter of its
  // views (paper take without masks, bench/sequence/flicker.py: flicker over the still
  // parts 1.07 mm against 0.32 with a half, when unobserved voxels were carried too).
  double changed_fraction = 0.5;
  // Throws core::InputError naming the field ("temporal.fusion_decay").
  void Check() const;
};

// One camera's view of what changed between the two instants.
struct ChangeView {
  geometry::TsaiCamera camera;  // the camera the tiles are on (its distorted pixel grid)
  cv::Mat changed_tiles;        // CV_8UC1, ceil(h / tile_px) x ceil(w / tile_px); 1: changed
  int tile_px = 32;             // tile edge, px
};

struct TemporalCarryStats {
  int64_t blocks = 0;          // blocks of the slab
  int64_t still_blocks = 0;    // observed at both instants and judged still
  int64_t voxels_carried = 0;  // voxels whose previous evidence was added
};

// Adds `previous`'s evidence to `slab` (both planes k0..k1 of `grid`, the same planes)
// in its still blocks, per the rule above. Throws core::InputError naming `where` when
// the slabs differ in planes or size, or a view's tiles do not cut its camera's image.
void CarryStill(const VolumeGrid& grid, const Slab& previous, const std::vector<ChangeView>& views,
                const TemporalCarryOptions& options, const std::string& where, Slab* slab,
                TemporalCarryStats* stats = nullptr);

}  // namespace dome::fusion
