// Analytic signed-distance volumes for marching-cubes tests, and mesh measures.
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "fusion/volume.h"
#include "io/mesh.h"

namespace dome::testing {

struct Volume {
  fusion::VolumeGrid grid;
  std::vector<float> distance;
  std::vector<float> weight;
};

// A sphere (distance positive outside) of `radius_vox` voxels, off-centre so no
// voxel value is exactly 0.
inline Volume SphereVolume(int n, double radius_vox) {
  Volume v;
  v.grid.voxel_size_mm = 2.0;
  v.grid.nx = v.grid.ny = v.grid.nz = n;
  v.grid.origin_mm = Eigen::Vector3d(-n, -n, -n);  // n voxels of 2 mm, centred at 0
  const Eigen::Vector3d c(0.173, -0.291, 0.117);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector3d p = v.grid.VoxelCentreMm(i, j, k);
        v.distance.push_back(float((p - c).norm() - radius_vox * v.grid.voxel_size_mm));
        v.weight.push_back(1.0f);
      }
  return v;
}

// Random values with a positive (outside) border: a closed surface hitting every
// marching-cubes case, including the ambiguous ones.
inline Volume RandomVolume(int n, uint32_t seed) {
  Volume v;
  v.grid.voxel_size_mm = 1.0;
  v.grid.nx = v.grid.ny = v.grid.nz = n;
  v.grid.origin_mm = Eigen::Vector3d::Zero();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const bool border = i == 0 || j == 0 || k == 0 || i == n - 1 || j == n - 1 || k == n - 1;
        float x = u(rng);
        if (x == 0.0f) x = 0.5f;
        v.distance.push_back(border ? 1.0f : x);
        v.weight.push_back(1.0f);
      }
  return v;
}

// The least area of any face of `m` (mesh units squared; infinity without faces).
inline double LeastFaceArea(const io::Mesh& m) {
  double least = std::numeric_limits<double>::infinity();
  for (const auto& f : m.faces) {
    const Eigen::Vector3d a = m.vertices[f[0]].cast<double>(), b = m.vertices[f[1]].cast<double>(),
                          c = m.vertices[f[2]].cast<double>();
    least = std::min(least, (b - a).cross(c - a).norm() / 2);
  }
  return least;
}

}  // namespace dome::testing
