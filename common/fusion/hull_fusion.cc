#include "fusion/hull_fusion.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.h"
#include "core/parallel_for.h"

namespace dome::fusion {

void HullFusionOptions::Check() const {
  core::Require(std::isfinite(hull_weight) && hull_weight > 0, "HullFusionOptions: hull_weight",
                "expected a positive weight, got " + std::to_string(hull_weight));
}

void ApplyHull(const VolumeGrid& grid, const silhouette::VisualHull& hull,
               const silhouette::PhotoHull* photo, const FusionOptions& options,
               const HullFusionOptions& hull_options, Slab* slab) {
  hull_options.Check();
  const int votes = hull.options().carve_votes;
  const float clamp = float(options.front_clamp_mm);
  const float truncation = float(options.truncation_mm);
  const float hull_weight = float(hull_options.hull_weight);
  const int64_t plane = int64_t(slab->nx) * slab->ny;
  // One voxel's verdict from its sample (the rule above), applied to the slab.
  auto apply = [&](int i, int j, int64_t k, float* d, float* w) {
    const int64_t v = int64_t(j) * slab->nx + i;
    // Stereo's clamped free space needs no hull: it is free space either way.
    if (w[v] > 0 && d[v] >= clamp) return;
    // Once carve_votes cameras say background and one puts the voxel a clamp or more
    // outside, the rest cannot change what it becomes: free space at the clamp.
    const Eigen::Vector3d centre = grid.VoxelCentreMm(i, j, double(k));
    const silhouette::HullSample s = hull.Sample(centre, 0.0, -1, clamp);
    bool free = false;
    float outside = 0;  // free space this far outside (the clamp at most)
    float inside = truncation;
    if (s.seen >= 1 && s.background >= std::min(votes, s.seen)) {
      free = true;
      outside = std::min(clamp, float(s.outside_mm));
    } else if (s.inside) {
      inside = std::min(truncation, float(s.inside_mm));
      if (photo) {
        const float carved = float(photo->CarvedDistanceMm(centre));
        free = carved > 0;
        if (free)
          outside = std::min(clamp, carved);
        else
          inside = std::min(inside, -carved);
      }
    }
    if (free) {
      d[v] = std::max(w[v] > 0 ? d[v] : 0.0f, outside);
      if (w[v] <= 0) w[v] = hull_weight;
    } else if (hull_options.fill_unseen && s.inside && w[v] <= 0) {
      d[v] = -inside;
      w[v] = hull_weight;
    }
  };
  // Blocks of kBlock^3 voxels that carve_votes cameras see a clamp or more outside their
  // silhouettes (VisualHull::CarvedBox) are free space at the clamp in every voxel, as
  // each voxel's own sample would find (its cameras stop at the clamp): one test instead
  // of a sample per voxel. Most of a volume shrunk to the hull's box of a few people is
  // such space (a Panoptic fusion job sampled the hull in half its time).
  // (Without distances a sample's outside is a pixel's footprint: no box test.)
  constexpr int kBlock = 8;
  const bool boxes = hull.options().distances && clamp > 0;
  core::ParallelFor(slab->k0, slab->k1, hull_options.num_threads, [&](int64_t k0, int64_t k1) {
    for (int64_t kb = k0; kb < k1; kb += kBlock) {
      const int64_t ke = std::min(k1, kb + kBlock);
      for (int jb = 0; jb < slab->ny; jb += kBlock) {
        const int je = std::min(slab->ny, jb + kBlock);
        for (int ib = 0; ib < slab->nx; ib += kBlock) {
          const int ie = std::min(slab->nx, ib + kBlock);
          const bool carved =
              boxes && hull.CarvedBox(grid.VoxelCentreMm(ib, jb, double(kb)),
                                      grid.VoxelCentreMm(ie - 1, je - 1, double(ke - 1)), clamp);
          for (int64_t k = kb; k < ke; ++k) {
            float* d = slab->distance_mm.data() + (k - slab->k0) * plane;
            float* w = slab->weight.data() + (k - slab->k0) * plane;
            for (int j = jb; j < je; ++j) {
              for (int i = ib; i < ie; ++i) {
                if (!carved) {
                  apply(i, j, k, d, w);
                  continue;
                }
                const int64_t v = int64_t(j) * slab->nx + i;
                if (w[v] > 0 && d[v] >= clamp) continue;
                d[v] = std::max(w[v] > 0 ? d[v] : 0.0f, clamp);
                if (w[v] <= 0) w[v] = hull_weight;
              }
            }
          }
        }
      }
    }
  });
}

}  // namespace dome::fusion
