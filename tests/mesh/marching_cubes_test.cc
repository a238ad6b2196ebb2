#include "mesh/marching_cubes.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <random>
#include <set>

#include "fusion/fusion_test_util.h"
#include "fusion/integrate.h"
#include "io/ply.h"
#include "mesh/mesh_test_util.h"
#include "testing/expect_error.h"

namespace dome::mesh {
namespace {

double SignedVolume(const io::Mesh& m) {
  double v = 0;
  for (const auto& f : m.faces) {
    v += m.vertices[f[0]].cast<double>().dot(
             m.vertices[f[1]].cast<double>().cross(m.vertices[f[2]].cast<double>())) /
         6.0;
  }
  return v;
}

TEST(MarchingCubes, SphereIsClosedOrientedAndAccurate) {
  const auto v = testing::SphereVolume(40, 12.0);
  const io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  ASSERT_GT(m.faces.size(), 1000u);
  EXPECT_EQ(m.Inconsistency(), "");
  const MeshTopology t = AnalyzeTopology(m);
  EXPECT_EQ(t.boundary_edges, 0);
  EXPECT_EQ(t.non_manifold_edges, 0);
  EXPECT_EQ(t.inconsistent_edges, 0);
  // Euler characteristic of a sphere: V - E + F = 2.
  EXPECT_EQ(int64_t(m.vertices.size()) - t.edges + int64_t(m.faces.size()), 2);
  const double r = 24.0;  // mm
  EXPECT_NEAR(SurfaceAreaMm2(m), 4 * M_PI * r * r, 0.01 * 4 * M_PI * r * r);
  // Counter-clockwise from outside: positive enclosed volume.
  EXPECT_NEAR(SignedVolume(m), 4.0 / 3 * M_PI * r * r * r, 0.01 * 4.0 / 3 * M_PI * r * r * r);
  const Eigen::Vector3d c(0.173, -0.291, 0.117);
  for (const auto& p : m.vertices) EXPECT_NEAR((p.cast<double>() - c).norm(), r, 0.05);
}

TEST(MarchingCubes, EveryCaseIsWatertight) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    const auto v = testing::RandomVolume(16, seed);
    const io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
    const MeshTopology t = AnalyzeTopology(m);
    EXPECT_EQ(t.boundary_edges, 0) << seed;
    EXPECT_EQ(t.non_manifold_edges, 0) << seed;
    EXPECT_EQ(t.inconsistent_edges, 0) << seed;
  }
}

// Corners at distance exactly 0 (a diagonal plane through voxel centres, and a random
// volume with a fifth of its values 0): the vertices of the edges around such a corner
// are kept apart, so no triangle loses its area (tools that divide by it, such as
// closest-point queries, fail on such triangles), while the surface stays put and
// closed.
TEST(MarchingCubes, ZeroCornersGiveNoDegenerateTriangles) {
  testing::Volume plane;
  plane.grid.voxel_size_mm = 1.0;
  plane.grid.nx = plane.grid.ny = plane.grid.nz = 12;
  plane.grid.origin_mm = Eigen::Vector3d::Zero();
  for (int k = 0; k < 12; ++k)
    for (int j = 0; j < 12; ++j)
      for (int i = 0; i < 12; ++i) {
        plane.distance.push_back(float(i + j + k - 15));  // 0 on the plane i + j + k = 15
        plane.weight.push_back(1.0f);
      }
  auto random = testing::RandomVolume(16, 4);
  for (size_t n = 0; n < random.distance.size(); n += 5) {
    if (random.distance[n] < 0) random.distance[n] = 0.0f;
  }
  for (const auto* v : {&plane, &random}) {
    const io::Mesh m = MarchingCubes(v->grid, v->distance, v->weight);
    ASSERT_GT(m.faces.size(), 100u);
    // voxel^2; three vertices 1e-3 voxel from their corner make 5e-7.
    EXPECT_GT(testing::LeastFaceArea(m), 1e-7);
    if (v == &random) {
      EXPECT_EQ(AnalyzeTopology(m).boundary_edges, 0);
    }
  }
  // On the plane (distance along the axes, not the normal: |n| = sqrt 3) every vertex is
  // within 1e-3 voxel of its true crossing.
  for (const auto& p : MarchingCubes(plane.grid, plane.distance, plane.weight).vertices) {
    EXPECT_NEAR((p.x() - 0.5) + (p.y() - 0.5) + (p.z() - 0.5), 15.0, 1.001e-3);
  }
}

TEST(MarchingCubes, UnobservedCellsAreSkipped) {
  auto v = testing::SphereVolume(30, 8.0);
  const size_t full = MarchingCubes(v.grid, v.distance, v.weight).faces.size();
  // Unobserve the half x < 0: the surface there disappears and leaves a boundary.
  for (int k = 0; k < 30; ++k)
    for (int j = 0; j < 30; ++j)
      for (int i = 0; i < 15; ++i) v.weight[(size_t(k) * 30 + j) * 30 + i] = 0;
  const io::Mesh half = MarchingCubes(v.grid, v.distance, v.weight);
  EXPECT_LT(half.faces.size(), full * 0.6);
  EXPECT_GT(half.faces.size(), full * 0.4);
  EXPECT_GT(AnalyzeTopology(half).boundary_edges, 0);
  for (const auto& p : half.vertices) EXPECT_GT(p.x(), -1.0f);
}

// Rows wider than the blocks the cell test runs in (203 cells: three blocks of 64 and a
// tail), with random unobserved voxels, NaN weights and NaN distances: a vertex is made
// on exactly the sign-changing edges of the cells the rule polygonizes (all 8 corners
// with weight > 0; a NaN weight unobserved, a NaN distance outside), counted here cell
// by cell, and the surface stays consistently oriented.
TEST(MarchingCubes, WideRowsWithHolesFollowTheCellRule) {
  testing::Volume v;
  v.grid.voxel_size_mm = 1.0;
  v.grid.nx = 204, v.grid.ny = 6, v.grid.nz = 5;
  v.grid.origin_mm = Eigen::Vector3d::Zero();
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const size_t n = size_t(v.grid.nx) * v.grid.ny * v.grid.nz;
  for (size_t i = 0; i < n; ++i) {
    // Long runs of unobserved space (every 8-cell skip) between observed stretches.
    const bool run_unobserved = (i / 37) % 3 == 1;
    const float r = u(rng);
    v.distance.push_back(r > 0.95f ? nan : u(rng));
    v.weight.push_back(run_unobserved || r < -0.9f ? 0.0f : (r > 0.9f ? nan : 1.0f));
  }
  const io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  const int nx = v.grid.nx, ny = v.grid.ny, nz = v.grid.nz;
  auto at = [&](int i, int j, int k) { return (size_t(k) * ny + j) * nx + i; };
  auto inside = [&](size_t idx) { return v.distance[idx] < 0.0f; };
  std::set<std::pair<size_t, int>> edges;  // (lower corner, axis) of the expected vertices
  for (int k = 0; k + 1 < nz; ++k)
    for (int j = 0; j + 1 < ny; ++j)
      for (int i = 0; i + 1 < nx; ++i) {
        int in = 0;
        bool observed = true;
        for (int c = 0; c < 8; ++c) {
          const size_t idx = at(i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2));
          observed = observed && v.weight[idx] > 0.0f;
          in += inside(idx);
        }
        if (!observed || in == 0 || in == 8) continue;
        for (int c = 0; c < 8; ++c) {
          const int ci = i + (c & 1), cj = j + ((c >> 1) & 1), ck = k + (c >> 2);
          for (int axis = 0; axis < 3; ++axis) {
            const int di = axis == 0, dj = axis == 1, dk = axis == 2;
            if ((axis == 0 && ci > i) || (axis == 1 && cj > j) || (axis == 2 && ck > k)) continue;
            if (inside(at(ci, cj, ck)) != inside(at(ci + di, cj + dj, ck + dk))) {
              edges.insert({at(ci, cj, ck), axis});
            }
          }
        }
      }
  ASSERT_GT(edges.size(), 500u);
  EXPECT_EQ(m.vertices.size(), edges.size());
  EXPECT_EQ(m.Inconsistency(), "");
  const MeshTopology t = AnalyzeTopology(m);
  EXPECT_EQ(t.non_manifold_edges, 0);
  EXPECT_EQ(t.inconsistent_edges, 0);
  EXPECT_GT(t.boundary_edges, 0);  // the holes' rims
}

// Slab invariance end to end: fusion in 1, 7 and 300 slabs, streamed into marching
// cubes, gives byte-identical PLY files.
TEST(MarchingCubes, OneSevenAndThreeHundredSlabsGiveIdenticalMeshes) {
  const auto images = testing::RingImages(testing::StackedSpheres(), 8, 64, 48, {500, 1500, 2500});
  fusion::VolumeGrid g;
  g.voxel_size_mm = 10;
  g.nx = g.ny = 32;
  g.nz = 300;
  g.origin_mm = Eigen::Vector3d(-160, -160, 0);
  fusion::FusionOptions o;
  o.num_threads = 2;
  fusion::Integrator integrator(g, images, o);
  std::string reference;
  for (int slabs : {1, 7, 300}) {
    StreamingMarchingCubes mc(g);
    for (int s = 0; s < slabs; ++s) {
      mc.AddSlab(integrator.IntegrateSlab(g.nz * s / slabs, g.nz * (s + 1) / slabs));
    }
    const io::Mesh m = mc.Finish();
    ASSERT_GT(m.faces.size(), 500u);
    // Six spheres, each closed (the volume's x/y sides cut nothing: radius 110 < 160).
    const MeshTopology t = AnalyzeTopology(m);
    EXPECT_EQ(t.non_manifold_edges, 0);
    EXPECT_EQ(t.inconsistent_edges, 0);
    const std::string bytes = io::EncodePly(m);
    if (reference.empty()) {
      reference = bytes;
    } else {
      EXPECT_EQ(bytes, reference) << slabs << " slabs";
    }
  }
}

TEST(MarchingCubes, PlanesOutOfOrderAreRejected) {
  const auto v = testing::SphereVolume(10, 3.0);
  StreamingMarchingCubes mc(v.grid);
  fusion::Slab slab;
  slab.k0 = 1;
  slab.k1 = 2;
  slab.nx = slab.ny = 10;
  slab.distance_mm.assign(100, 1.0f);
  slab.weight.assign(100, 1.0f);
  testing::ExpectInputError([&] { mc.AddSlab(slab); }, {"plane 1", "plane 0 was expected"});
  slab.nx = 9;
  testing::ExpectInputError([&] { mc.AddSlab(slab); }, {"9x10", "10x10"});
  fusion::VolumeGrid bad = v.grid;
  bad.ny = 0;
  testing::ExpectInputError([&] { StreamingMarchingCubes x(bad); }, {"volume: ny"});
}

}  // namespace
}  // namespace dome::mesh
