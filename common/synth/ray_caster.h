// Exact ray casting of a SceneMesh with Embree 3 (Intel's ray-tracing kernels).
//
// Every ray returns the closest triangle it crosses, in single precision (Embree's
// watertight, robust mode), so a depth of a few metres is exact to ~1 um. The BVH is
// built single-threaded, which keeps it -- and therefore every tie between triangles
// -- identical from run to run; casting is thread-safe and is what ParallelFor spreads.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>

#include "synth/scene_mesh.h"

namespace dome::synth {

struct RayHit {
  static constexpr uint32_t kNoFace = 0xffffffffu;
  float t = 0.0f;     // ray parameter: hit = origin + t * direction
  uint32_t face = 0;  // index into SceneMesh::faces; kNoFace when the ray hits nothing
  float u = 0.0f;     // barycentric weight of the face's 2nd vertex
  float v = 0.0f;     // barycentric weight of the face's 3rd vertex
};

class RayCaster {
 public:
  // Keeps a pointer to `mesh`, which must outlive the caster and stay unchanged.
  explicit RayCaster(const SceneMesh& mesh);
  ~RayCaster();
  RayCaster(const RayCaster&) = delete;
  RayCaster& operator=(const RayCaster&) = delete;

  // Closest hit with t in (t_min, infinity); false when the ray hits nothing. The
  // direction need not be unit length (t is then in units of its length).
  bool Intersect(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction, RayHit* hit,
                 float t_min = 0.0f) const;

  // Casts `count` rays from one origin (e.g. a row of pixels) in coherent packets of
  // 16; hits[i].face is RayHit::kNoFace where ray i hits nothing. Same results as
  // Intersect, faster for neighbouring rays.
  void IntersectMany(const Eigen::Vector3f& origin, const Eigen::Vector3f* directions, int count,
                     RayHit* hits) const;

  const SceneMesh& mesh() const { return *mesh_; }

 private:
  struct Impl;
  const SceneMesh* mesh_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dome::synth
