// Defaults derived from other options, written once (the seed's volume and fusion rule;
// SPEC.md "Pipeline"). Every command and every job takes them from here:
//   * the volume: the seed's 6 m cube around the dome (min corner -3000, -3000, -2750
//     mm), cut into voxels of the given edge: round(6000 mm / voxel) voxels an axis;
//   * fusion: truncation and free-space clamp 3 voxels (Curless and Levoy's ramp
//     half-width, seed §3), the multi-view consistency tolerance one voxel.
#pragma once

#include "fusion/integrate.h"
#include "fusion/volume.h"

namespace dome::pipeline {

inline constexpr double kSeedCubeMm = 6000.0;      // edge of the seed's volume, mm
inline constexpr double kDefaultVoxelMm = 20.0;    // the seed's voxel edge, mm
inline constexpr double kTruncationVoxels = 3.0;   // truncation and clamp, voxels
inline constexpr double kConsistencyVoxels = 1.0;  // consistency tolerance, voxels

// The seed's cube of `voxel_size_mm` voxels (not checked: a bad size fails the grid's
// Check with the caller's name for it).
fusion::VolumeGrid DefaultVolume(double voxel_size_mm = kDefaultVoxelMm);

// The library's fusion options with the voxel-derived ones set for `voxel_size_mm`.
fusion::FusionOptions DefaultFusionOptions(double voxel_size_mm);

}  // namespace dome::pipeline
