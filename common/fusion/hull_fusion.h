// Silhouettes in fusion: a fused slab (fusion/integrate.h) corrected by the visual hull
// of the instant's masks (silhouette/hull.h), after the range images are integrated.
//
// Per voxel centre (world mm), with the hull's votes on it:
//  * free space: at least one camera sees the voxel and at least min(carve_votes, seen)
//    of the cameras that see it place it outside their (dilated) masks -- the hull's
//    own rule, so with the default two votes one camera's mask that misses a part never
//    empties it. The voxel's distance becomes at least its distance outside the hull
//    (the largest of the background cameras' cone distances, a lower bound of the true
//    one), capped at front_clamp_mm: a free-space value, whatever stereo put there (the
//    wrong matches that float in the air). An unobserved one gets hull_weight.
//  * with fill_unseen only, the hull's surface stands in: a voxel in the hull that no
//    range image updated (weight 0: the cameras are far apart, the clothes without
//    texture) gets the hull's signed distance, minus its distance inside the hull capped
//    at truncation_mm, with hull_weight, below one range image's weight of 1 (uniform
//    weights), so that where any range image saw the voxel, stereo decides.
//  * with a photo hull (silhouette/photo_hull.h, the hull carved where the cameras see
//    inconsistent colours), a voxel in the hull on the carved side of its border is free
//    space as outside the hull (its distance the photo hull's, at most front_clamp_mm),
//    and the hull's surface standing in is the photo hull's: a distance inside the hull
//    is at most the distance to the carved border.
// Voxels stereo updated inside the hull (and not carved) keep stereo's values. Distances are mm
// along the surface normal (the cones' lateral distance), d > 0 in front of the surface, as the
// range images' are along their rays.
#pragma once

#include "fusion/integrate.h"
#include "fusion/volume.h"
#include "silhouette/hull.h"
#include "silhouette/photo_hull.h"

namespace dome::fusion {

struct HullFusionOptions {
  // Weight of the hull's distances (uniform range-image weights are 1 per image): half an
  // image, so one range image that saw a voxel outweighs the hull.
  double hull_weight = 0.5;
  // The hull's surface where no range image saw a voxel (above). Off by default: where
  // a dense rig's stereo sees nothing inside the hull is mostly the hull's ghost volume
  // (a concavity, the space between the arms, that no silhouette carves), and its
  // surface there is far from the scene's. Paper take (51 cameras, fusion the only use
  // of the masks, 11 instants, medians): accuracy p90 19.5 mm without, 34.5 mm with;
  // completeness within 10 mm 0.602 and 0.607.
  bool fill_unseen = false;
  int num_threads = 0;  // <= 0: all hardware threads
  void Check() const;
};

// Applies the rules above to `slab` (planes k0..k1 of `grid`), with fusion's truncation
// and clamp from `options`; `photo` may be null (no carving).
void ApplyHull(const VolumeGrid& grid, const silhouette::VisualHull& hull,
               const silhouette::PhotoHull* photo, const FusionOptions& options,
               const HullFusionOptions& hull_options, Slab* slab);

}  // namespace dome::fusion
