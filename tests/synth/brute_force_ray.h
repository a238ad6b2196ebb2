// Test reference for ray casting: Moller-Trumbore in double precision over every
// triangle of a mesh, independent of Embree. Works for synth::SceneMesh and io::Mesh
// (anything with `vertices` of Vector3f and `faces` of 3 indices).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstddef>
#include <limits>

namespace dome::testing {

struct BruteForceHit {
  double t = std::numeric_limits<double>::infinity();  // ray parameter of the nearest hit
  int face = -1;                                       // its triangle, -1 for none
  double u = 0.0;                                      // barycentric coordinates of the hit
  double v = 0.0;
  bool hit() const { return face >= 0; }
};

// The nearest intersection with t > 1e-9 of the ray o + t d.
template <typename Mesh>
BruteForceHit BruteForceIntersect(const Mesh& mesh, const Eigen::Vector3d& o,
                                  const Eigen::Vector3d& d) {
  BruteForceHit best;
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    const Eigen::Vector3d a = mesh.vertices[mesh.faces[f][0]].template cast<double>();
    const Eigen::Vector3d e1 = mesh.vertices[mesh.faces[f][1]].template cast<double>() - a;
    const Eigen::Vector3d e2 = mesh.vertices[mesh.faces[f][2]].template cast<double>() - a;
    const Eigen::Vector3d p = d.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < 1e-14) continue;
    const Eigen::Vector3d s = o - a;
    const double u = s.dot(p) / det;
    if (u < 0 || u > 1) continue;
    const Eigen::Vector3d q = s.cross(e1);
    const double v = d.dot(q) / det;
    if (v < 0 || u + v > 1) continue;
    const double t = e2.dot(q) / det;
    if (t > 1e-9 && t < best.t) best = {t, static_cast<int>(f), u, v};
  }
  return best;
}

}  // namespace dome::testing
