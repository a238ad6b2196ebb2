#include "synth/ray_caster.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>

#include "brute_force_ray.h"
#include "synth/noise.h"
#include "synth/scene.h"

namespace dome::synth {
namespace {

using Eigen::Vector3d;

bool BruteForce(const SceneMesh& mesh, const Vector3d& o, const Vector3d& d, double* t_best,
                int* face_best) {
  const dome::testing::BruteForceHit hit = dome::testing::BruteForceIntersect(mesh, o, d);
  *t_best = hit.t;
  *face_best = hit.face;
  return hit.hit();
}

TEST(RayCaster, AgreesWithBruteForceOnTheDomeScene) {
  const SceneMesh mesh = BuildDomeScene(0.7);
  const RayCaster caster(mesh);
  Rng rng(11);
  int hits = 0, same_face = 0, misses = 0;
  for (int i = 0; i < 600; ++i) {
    // From points on the dome towards points around the person (many hit the body).
    const Vector3d o(rng.Uniform(-2500, 2500), rng.Uniform(-2500, 2500), rng.Uniform(500, 2800));
    const Vector3d target(rng.Uniform(-600, 600), rng.Uniform(-600, 600), rng.Uniform(0, 2500));
    const Vector3d d =
        i % 5 == 4 ? Vector3d(rng.Uniform(-1, 1), rng.Uniform(-1, 1), 1.0) : Vector3d(target - o);
    const Eigen::Vector3f of = o.cast<float>(), df = d.cast<float>();
    double t_ref;
    int face_ref;
    const bool ref = BruteForce(mesh, of.cast<double>(), df.cast<double>(), &t_ref, &face_ref);
    RayHit hit;
    const bool got = caster.Intersect(of, df, &hit);
    ASSERT_EQ(got, ref) << "ray " << i;
    if (!ref) {
      ++misses;
      continue;
    }
    ++hits;
    EXPECT_NEAR(hit.t, t_ref, 1e-5 * t_ref + 1e-6) << "ray " << i;
    if (static_cast<int>(hit.face) != face_ref) {
      // Only a tie (a shared edge) may pick another face, at the same distance.
      EXPECT_NEAR(hit.t, t_ref, 1e-5 * t_ref);
    } else {
      ++same_face;
    }
    // Barycentrics reproduce the hit point.
    const auto& f = mesh.faces[hit.face];
    const Eigen::Vector3f p = (1 - hit.u - hit.v) * mesh.vertices[f[0]] +
                              hit.u * mesh.vertices[f[1]] + hit.v * mesh.vertices[f[2]];
    EXPECT_LT((p - (of + hit.t * df)).norm(), 1e-2f);
  }
  EXPECT_GT(hits, 400);
  EXPECT_GT(misses, 10);  // rays into the open sky
  EXPECT_GT(same_face, hits - 5);
}

TEST(RayCaster, PacketsMatchSingleRays) {
  const SceneMesh mesh = BuildDomeScene(0.3);
  const RayCaster caster(mesh);
  const Eigen::Vector3f origin(1800, -1500, 1600);
  std::vector<Eigen::Vector3f> dirs;
  for (int i = 0; i < 77; ++i) {  // not a multiple of 16
    dirs.emplace_back(-1.0f + 0.004f * i, 0.9f, -0.35f + 0.003f * i);
  }
  std::vector<RayHit> many(dirs.size());
  caster.IntersectMany(origin, dirs.data(), static_cast<int>(dirs.size()), many.data());
  for (size_t i = 0; i < dirs.size(); ++i) {
    RayHit one;
    const bool got = caster.Intersect(origin, dirs[i], &one);
    ASSERT_EQ(got, many[i].face != RayHit::kNoFace);
    if (!got) continue;
    EXPECT_EQ(one.face, many[i].face);
    EXPECT_NEAR(one.t, many[i].t, 1e-4f * one.t);
  }
}

TEST(RayCaster, EmptySceneMissesEverything) {
  const SceneMesh mesh;
  const RayCaster caster(mesh);
  RayHit hit;
  EXPECT_FALSE(caster.Intersect(Eigen::Vector3f::Zero(), Eigen::Vector3f::UnitZ(), &hit));
}

}  // namespace
}  // namespace dome::synth
