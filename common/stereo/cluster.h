// Stereo clusters: a reference camera and its immediate neighbours on the dome
// (seed §4.3: 4-7 cameras per cluster).
//
// When rig.json names a camera's neighbours (take/rig.h) they are the cluster, in the
// order given. Otherwise the cluster is derived from the geometry: the cameras whose
// optical axes are within max_axis_angle_deg of the reference's (so they see the same
// side of the scene), nearest camera centre first, at most max_neighbours of them. On a
// sparse rig where no camera is within that angle, the (at most two) cameras nearest in
// axis angle up to 135 degrees are taken instead, and the reason is logged.
#pragma once

#include <string>
#include <vector>

#include "geometry/rig.h"

namespace dome::stereo {

struct ClusterOptions {
  int max_neighbours = 6;            // cameras besides the reference (count, >= 1)
  double max_axis_angle_deg = 60.0;  // largest angle between optical axes, in degrees

  // Throws core::InputError naming the first option out of range.
  void Check() const;
};

// Indices into rig.cameras of the reference's neighbours. Throws core::InputError when
// `camera_id` is not in the rig, or when the cluster would hold only the reference.
std::vector<int> SelectCluster(const geometry::Rig& rig, const std::string& camera_id,
                               const ClusterOptions& options);

// The median over the rig's cameras of the angle between a camera's optical axis and the
// nearest other camera's, in degrees (0 for a rig of one camera): how far apart the
// views that stereo pairs are.
double MedianNearestAxisAngleDeg(const geometry::Rig& rig);

}  // namespace dome::stereo
