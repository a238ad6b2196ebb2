#include "stereo/cluster.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/error.h"

namespace dome::stereo {

void ClusterOptions::Check() const {
  core::Require(max_neighbours >= 1, "max_neighbours",
                "must be at least 1, got " + std::to_string(max_neighbours));
  core::Require(
      std::isfinite(max_axis_angle_deg) && max_axis_angle_deg > 0.0 && max_axis_angle_deg <= 180.0,
      "max_axis_angle_deg", "must be in (0, 180], got " + std::to_string(max_axis_angle_deg));
}

std::vector<int> SelectCluster(const geometry::Rig& rig, const std::string& camera_id,
                               const ClusterOptions& options) {
  options.Check();
  const int ref = rig.Find(camera_id);
  core::Require(ref >= 0, "--camera", "camera '" + camera_id + "' is not in the rig");
  std::vector<int> cluster;
  const auto& named = rig.cameras[ref].neighbours;
  if (!named.empty()) {
    for (const auto& id : named) {
      const int j = rig.Find(id);
      core::Require(j >= 0 && j != ref, "rig.json: camera '" + camera_id + "'.neighbours",
                    "names '" + id + "', which is not another camera of the rig");
      cluster.push_back(j);
    }
  } else {
    const auto& rc = rig.cameras[ref].model;
    const Eigen::Vector3d axis = rc.rotation.row(2).transpose();
    const Eigen::Vector3d centre = rc.CentreWorld();
    const double cos_max = std::cos(options.max_axis_angle_deg * M_PI / 180.0);
    std::vector<std::pair<double, int>> candidates;
    for (int j = 0; j < static_cast<int>(rig.cameras.size()); ++j) {
      if (j == ref) continue;
      const auto& c = rig.cameras[j].model;
      const Eigen::Vector3d aj = c.rotation.row(2).transpose();
      if (axis.dot(aj) < cos_max) continue;
      candidates.emplace_back((c.CentreWorld() - centre).norm(), j);
    }
    std::sort(candidates.begin(), candidates.end());
    for (size_t k = 0; k < candidates.size() && static_cast<int>(k) < options.max_neighbours; ++k)
      cluster.push_back(candidates[k].second);
    if (cluster.empty()) {
      // A sparse rig: no camera looks the same way. The cameras nearest in axis angle
      // still share parts of the scene; stereo between axes up to kFallbackAngleDeg apart
      // finds them (beyond, the cameras face each other and see opposite sides).
      constexpr double kFallbackAngleDeg = 135.0;
      std::vector<std::pair<double, int>> by_angle;
      for (int j = 0; j < static_cast<int>(rig.cameras.size()); ++j) {
        if (j == ref) continue;
        const Eigen::Vector3d aj = rig.cameras[j].model.rotation.row(2).transpose();
        const double deg = std::acos(std::clamp(axis.dot(aj), -1.0, 1.0)) * 180.0 / M_PI;
        if (deg <= kFallbackAngleDeg) by_angle.emplace_back(deg, j);
      }
      std::sort(by_angle.begin(), by_angle.end());
      std::string names;
      for (size_t k = 0; k < by_angle.size() && int(k) < std::min(2, options.max_neighbours); ++k) {
        cluster.push_back(by_angle[k].second);
        names += (k ? ", " : "") + rig.cameras[by_angle[k].second].model.id + " (" +
                 std::to_string(int(std::lround(by_angle[k].first))) + " deg)";
      }
      if (!cluster.empty()) {
        spdlog::info(
            "cluster of {}: no camera within {:g} degrees of its axis; using the nearest "
            "in axis angle: {}",
            camera_id, options.max_axis_angle_deg, names);
      }
    }
  }
  core::Require(!cluster.empty(), "cluster",
                "camera '" + camera_id +
                    "' has no neighbours (a cluster of one camera): name them in rig.json or "
                    "add cameras whose optical axes are within 135 degrees of it");
  return cluster;
}

double MedianNearestAxisAngleDeg(const geometry::Rig& rig) {
  std::vector<double> nearest;
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const Eigen::Vector3d ai = rig.cameras[i].model.rotation.row(2).transpose();
    double best = 180.0;
    for (size_t j = 0; j < rig.cameras.size(); ++j) {
      if (j == i) continue;
      const Eigen::Vector3d aj = rig.cameras[j].model.rotation.row(2).transpose();
      best = std::min(best, std::acos(std::clamp(ai.dot(aj), -1.0, 1.0)) * 180.0 / M_PI);
    }
    if (rig.cameras.size() > 1) nearest.push_back(best);
  }
  if (nearest.empty()) return 0.0;
  std::nth_element(nearest.begin(), nearest.begin() + nearest.size() / 2, nearest.end());
  return nearest[nearest.size() / 2];
}

}  // namespace dome::stereo
