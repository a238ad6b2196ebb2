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
  core::ParallelFor(slab->k0, slab->k1, hull_options.num_threads, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k) {
      float* d = slab->distance_mm.data() + (k - slab->k0) * plane;
      float* w = slab->weight.data() + (k - slab->k0) * plane;
      for (int j = 0; j < slab->ny; ++j) {
        for (int i = 0; i < slab->nx; ++i) {
          const int64_t v = int64_t(j) * slab->nx + i;
          // Stereo's clamped free space needs no hull: it is free space either way.
          if (w[v] > 0 && d[v] >= clamp) continue;
          // Once carve_votes cameras say background and one puts the voxel a clamp or
          // more outside, the rest cannot change what it becomes: free space at the clamp.
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
        }
      }
    }
  });
}

}  // namespace dome::fusion
