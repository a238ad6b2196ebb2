#include "pipeline/defaults.h"

#include <cmath>

namespace dome::pipeline {

fusion::VolumeGrid DefaultVolume(double voxel_size_mm) {
  fusion::VolumeGrid g;  // its origin is the seed cube's min corner
  g.voxel_size_mm = voxel_size_mm;
  const double n = std::isfinite(voxel_size_mm) && voxel_size_mm > 0
                       ? std::round(kSeedCubeMm / voxel_size_mm)
                       : 0.0;
  // A voxel so small that the count overflows is refused by the grid's Check (0 voxels).
  g.nx = g.ny = g.nz = n >= 1 && n <= 1 << 20 ? int(n) : 0;
  return g;
}

fusion::FusionOptions DefaultFusionOptions(double voxel_size_mm) {
  fusion::FusionOptions o;
  o.truncation_mm = o.front_clamp_mm = kTruncationVoxels * voxel_size_mm;
  o.consistency_tolerance_mm = kConsistencyVoxels * voxel_size_mm;
  return o;
}

}  // namespace dome::pipeline
