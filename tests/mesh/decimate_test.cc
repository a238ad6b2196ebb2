#include "mesh/decimate.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "mesh/marching_cubes.h"
#include "mesh/mesh_test_util.h"
#include "testing/expect_error.h"

namespace dome::mesh {
namespace {

TEST(Decimate, TenPercentKeepsASphereClosedAndClose) {
  const auto v = testing::SphereVolume(60, 25.0);
  const io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  DecimationOptions o;
  o.target_ratio = 0.1;
  DecimationSummary summary;
  const io::Mesh d = Decimate(m, o, &summary);
  EXPECT_EQ(summary.triangles_in, int64_t(m.faces.size()));
  EXPECT_LE(d.faces.size(), m.faces.size() / 10 + 2);
  EXPECT_GE(d.faces.size(), m.faces.size() / 12);
  EXPECT_EQ(d.Inconsistency(), "");
  const MeshTopology t = AnalyzeTopology(d);
  EXPECT_EQ(t.boundary_edges, 0);
  EXPECT_EQ(t.non_manifold_edges, 0);
  EXPECT_EQ(int64_t(d.vertices.size()) - t.edges + int64_t(d.faces.size()), 2);
  const Eigen::Vector3d c(0.173, -0.291, 0.117);
  for (const auto& p : d.vertices) EXPECT_NEAR((p.cast<double>() - c).norm(), 50.0, 0.5);
  EXPECT_NEAR(SurfaceAreaMm2(d), SurfaceAreaMm2(m), 0.02 * SurfaceAreaMm2(m));
}

// Mean distance to the true sphere of points spread over the triangles (vertices, edge
// midpoints and centroids), mm.
double MeanSphereError(const io::Mesh& m, const Eigen::Vector3d& c, double r) {
  double sum = 0;
  int n = 0;
  for (const auto& f : m.faces) {
    const Eigen::Vector3d a = m.vertices[f[0]].cast<double>(), b = m.vertices[f[1]].cast<double>(),
                          d = m.vertices[f[2]].cast<double>();
    for (const Eigen::Vector3d& p :
         {a, b, d, Eigen::Vector3d((a + b) / 2), Eigen::Vector3d((b + d) / 2),
          Eigen::Vector3d((a + d) / 2), Eigen::Vector3d((a + b + d) / 3)}) {
      sum += std::abs((p - c).norm() - r);
      ++n;
    }
  }
  return sum / n;
}

// The kept vertices moved to their quadric optimum put the coarse triangles across the
// curved surface instead of inside it: closer to the truth on average.
TEST(Decimate, RelocationBringsTheCoarseSurfaceCloser) {
  const auto v = testing::SphereVolume(60, 25.0);
  const io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  const Eigen::Vector3d c(0.173, -0.291, 0.117);
  DecimationOptions o;
  o.target_ratio = 0.05;
  o.relocate_vertices = false;
  const io::Mesh kept = Decimate(m, o);
  o.relocate_vertices = true;
  const io::Mesh moved = Decimate(m, o);
  ASSERT_EQ(kept.faces.size(), moved.faces.size());
  const double e_kept = MeanSphereError(kept, c, 50.0), e_moved = MeanSphereError(moved, c, 50.0);
  EXPECT_LT(e_moved, 0.9 * e_kept) << e_kept << " -> " << e_moved;
  const MeshTopology t = AnalyzeTopology(moved);
  EXPECT_EQ(t.boundary_edges, 0);
  EXPECT_EQ(t.inconsistent_edges, 0);
}

TEST(Decimate, ErrorBoundStopsEarlyAndBordersStay) {
  auto v = testing::SphereVolume(40, 15.0);
  for (size_t n = 0; n < v.weight.size() / 2; ++n) v.weight[n] = 0;  // an open half sphere
  const io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  DecimationOptions o;
  o.target_ratio = 0.01;
  o.max_error_mm = 0.05;
  const io::Mesh d = Decimate(m, o);
  EXPECT_GT(d.faces.size(), m.faces.size() / 100);
  EXPECT_EQ(AnalyzeTopology(d).non_manifold_edges, 0);
  // Locked border: every border vertex of the output is an input vertex.
  EXPECT_GT(AnalyzeTopology(d).boundary_edges, 0);
}

TEST(Decimate, BadOptionsAreRejected) {
  io::Mesh m;
  DecimationOptions o;
  o.target_ratio = 0;
  testing::ExpectInputError([&] { Decimate(m, o); }, {"decimation: target_ratio"});
  o = {};
  o.max_error_mm = -1;
  testing::ExpectInputError([&] { Decimate(m, o); }, {"decimation: max_error_mm"});
  o = {};
  m.vertices.push_back(Eigen::Vector3f::Zero());
  m.faces.push_back(Eigen::Vector3i(0, 1, 2));
  testing::ExpectInputError([&] { Decimate(m, o); }, {"decimation: mesh"});
}

}  // namespace
}  // namespace dome::mesh
