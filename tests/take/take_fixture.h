// Builds small, valid takes on disk for tests.
#pragma once

#include <filesystem>
#include <string>

#include "geometry/rig.h"

namespace dome::take::testing {

// A rig of `cameras` cameras (ids c0, c1, ...) on a circle of radius 2000 mm around
// the origin at height 1000 mm, looking at the origin, images width x height.
geometry::Rig MakeRingRig(int cameras, int width_px, int height_px);

// Writes rig.json and frames/<instant>/<camera>.png (gray noise) for instants
// 00-00-01-00, 00-00-01-05, ... Returns the take folder.
std::filesystem::path WriteTake(const std::filesystem::path& dir, const geometry::Rig& rig,
                                int instants);

}  // namespace dome::take::testing
