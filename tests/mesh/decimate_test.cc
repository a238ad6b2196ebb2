#include "mesh/decimate.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <set>
#include <tuple>
#include <utility>

#include "mesh/marching_cubes.h"
#include "mesh/mesh_test_util.h"
#include "testing/expect_error.h"

namespace dome::mesh {
namespace {

const Eigen::Vector3d kSphereCentre(0.173, -0.291, 0.117);  // SphereVolume's centre, mm

int64_t EulerCharacteristic(const io::Mesh& m) {
  return int64_t(m.vertices.size()) - AnalyzeTopology(m).edges + int64_t(m.faces.size());
}

// A torus around the z axis through (0.31, -0.17, 0.23) mm: major radius 30 mm, minor
// 12 mm, 1 mm voxels; distance positive outside.
testing::Volume TorusVolume() {
  testing::Volume v;
  const int n = 90;
  v.grid.voxel_size_mm = 1.0;
  v.grid.nx = v.grid.ny = v.grid.nz = n;
  v.grid.origin_mm = Eigen::Vector3d(-45, -45, -45);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector3d p =
            v.grid.VoxelCentreMm(i, j, k) - Eigen::Vector3d(0.31, -0.17, 0.23);
        const double q = std::hypot(p.x(), p.y()) - 30.0;
        v.distance.push_back(float(std::hypot(q, p.z()) - 12.0));
        v.weight.push_back(1.0f);
      }
  return v;
}

double TorusDistance(const Eigen::Vector3d& x) {
  const Eigen::Vector3d p = x - Eigen::Vector3d(0.31, -0.17, 0.23);
  return std::abs(std::hypot(std::hypot(p.x(), p.y()) - 30.0, p.z()) - 12.0);
}

// Largest distance to an analytic surface of points spread over each triangle (a
// barycentric grid of 15 points, corners included), mm.
template <typename Distance>
double MaxDistanceToSurface(const io::Mesh& m, Distance distance) {
  double worst = 0;
  for (const auto& f : m.faces) {
    const Eigen::Vector3d a = m.vertices[f[0]].cast<double>(), b = m.vertices[f[1]].cast<double>(),
                          c = m.vertices[f[2]].cast<double>();
    for (int i = 0; i <= 4; ++i)
      for (int j = 0; i + j <= 4; ++j) {
        const Eigen::Vector3d p = a + (b - a) * (i / 4.0) + (c - a) * (j / 4.0);
        worst = std::max(worst, distance(p));
      }
  }
  return worst;
}

// Distance from p to the triangle abc, mm.
double PointTriangleDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                             const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const double n2 = n.squaredNorm();
  if (n2 > 0) {
    // Inside the prism over the triangle: the plane distance.
    const Eigen::Vector3d q = p - n * (n.dot(p - a) / n2);
    const double u = (b - q).cross(c - q).dot(n), v = (c - q).cross(a - q).dot(n),
                 w = (a - q).cross(b - q).dot(n);
    if (u >= 0 && v >= 0 && w >= 0) return (p - q).norm();
  }
  auto segment = [&](const Eigen::Vector3d& s, const Eigen::Vector3d& t) {
    const Eigen::Vector3d d = t - s;
    const double l2 = d.squaredNorm();
    const double h = l2 > 0 ? std::clamp((p - s).dot(d) / l2, 0.0, 1.0) : 0.0;
    return (p - (s + h * d)).norm();
  };
  return std::min({segment(a, b), segment(b, c), segment(c, a)});
}

// Distance from p to the mesh's surface, mm (brute force).
double DistanceToMesh(const Eigen::Vector3d& p, const io::Mesh& m) {
  double best = HUGE_VAL;
  for (const auto& f : m.faces) {
    best = std::min(best, PointTriangleDistance(p, m.vertices[f[0]].cast<double>(),
                                                m.vertices[f[1]].cast<double>(),
                                                m.vertices[f[2]].cast<double>()));
  }
  return best;
}

// Largest distance from the given surface points to the mesh, mm (brute force).
double MaxDistanceToMesh(const std::vector<Eigen::Vector3d>& points, const io::Mesh& m) {
  double worst = 0;
  for (const auto& p : points) worst = std::max(worst, DistanceToMesh(p, m));
  return worst;
}

TEST(Decimate, ReachesTheExactTriangleCount) {
  const auto v = testing::SphereVolume(40, 15.0);
  const io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  ASSERT_GT(m.faces.size(), 4000u);
  for (int64_t target : {2000, 600, 100}) {
    DecimationOptions o;
    o.target_triangles = target;
    DecimationSummary s;
    const io::Mesh d = Decimate(m, o, &s);
    EXPECT_EQ(int64_t(d.faces.size()), target);
    EXPECT_EQ(s.triangles_out, target);
    EXPECT_EQ(s.triangles_in, int64_t(m.faces.size()));
    EXPECT_EQ(d.Inconsistency(), "");
  }
}

TEST(Decimate, TenPercentKeepsASphereClosedAndClose) {
  const auto v = testing::SphereVolume(60, 25.0);
  const io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  DecimationOptions o;
  o.target_ratio = 0.1;
  DecimationSummary summary;
  const io::Mesh d = Decimate(m, o, &summary);
  EXPECT_EQ(summary.triangles_in, int64_t(m.faces.size()));
  EXPECT_EQ(int64_t(d.faces.size()), std::llround(0.1 * double(m.faces.size())) / 2 * 2);
  EXPECT_EQ(d.Inconsistency(), "");
  const MeshTopology t = AnalyzeTopology(d);
  EXPECT_EQ(t.boundary_edges, 0);
  EXPECT_EQ(t.non_manifold_edges, 0);
  EXPECT_EQ(t.inconsistent_edges, 0);
  EXPECT_EQ(EulerCharacteristic(d), 2);
  // Two-sided Hausdorff distance to the true sphere (radius 50 mm): the mesh to the
  // sphere over the triangles, and the sphere (Fibonacci points) to the mesh.
  auto to_sphere = [](const Eigen::Vector3d& p) {
    return std::abs((p - kSphereCentre).norm() - 50);
  };
  EXPECT_LT(MaxDistanceToSurface(d, to_sphere), 0.5);
  std::vector<Eigen::Vector3d> on_sphere;
  for (int i = 0; i < 400; ++i) {
    const double z = 1 - (i + 0.5) / 200.0, phi = i * 2.399963229728653;
    const double r = std::sqrt(1 - z * z);
    on_sphere.push_back(kSphereCentre +
                        50.0 * Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), z));
  }
  EXPECT_LT(MaxDistanceToMesh(on_sphere, d), 0.5);
  EXPECT_NEAR(SurfaceAreaMm2(d), SurfaceAreaMm2(m), 0.01 * SurfaceAreaMm2(m));
  EXPECT_GT(summary.error_mm, 0.0);
  EXPECT_LT(summary.error_mm, 0.5);
}

TEST(Decimate, TenPercentKeepsATorusAGenusOneManifold) {
  const auto v = TorusVolume();
  const io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  ASSERT_EQ(EulerCharacteristic(m), 0);
  DecimationOptions o;
  o.target_ratio = 0.1;
  const io::Mesh d = Decimate(m, o);
  EXPECT_LE(d.faces.size(), m.faces.size() / 10 + 1);
  EXPECT_GE(d.faces.size(), m.faces.size() / 10 - 1);
  const MeshTopology t = AnalyzeTopology(d);
  EXPECT_EQ(t.boundary_edges, 0);
  EXPECT_EQ(t.non_manifold_edges, 0);
  EXPECT_EQ(t.inconsistent_edges, 0);
  EXPECT_EQ(EulerCharacteristic(d), 0);
  EXPECT_LT(MaxDistanceToSurface(d, TorusDistance), 0.4);
  std::vector<Eigen::Vector3d> on_torus;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 16; ++j) {
      const double a = 2 * M_PI * (i + 0.3) / 40, b = 2 * M_PI * (j + 0.7) / 16;
      const double q = 30 + 12 * std::cos(b);
      on_torus.push_back(Eigen::Vector3d(0.31, -0.17, 0.23) +
                         Eigen::Vector3d(q * std::cos(a), q * std::sin(a), 12 * std::sin(b)));
    }
  EXPECT_LT(MaxDistanceToMesh(on_torus, d), 0.4);
}

// An n x n vertex grid in the plane z = 3 mm, 1.5 mm spacing, slightly jittered in the
// plane so no collapse is a tie.
io::Mesh PlanarGrid(int n) {
  io::Mesh m;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const bool edge = i == 0 || j == 0 || i == n - 1 || j == n - 1;
      const float jitter = edge ? 0.0f : 0.1f * float(std::sin(7.0 * i + 3.0 * j));
      m.vertices.push_back(Eigen::Vector3f(1.5f * i + jitter, 1.5f * j - jitter, 3.0f));
    }
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i;
      m.faces.push_back(Eigen::Vector3i(a, a + 1, a + n + 1));
      m.faces.push_back(Eigen::Vector3i(a, a + n + 1, a + n));
    }
  return m;
}

TEST(Decimate, AFlatGridCollapsesWithZeroErrorToItsCorners) {
  const int n = 21;
  const io::Mesh m = PlanarGrid(n);
  DecimationOptions o;
  o.target_triangles = 1;
  o.lock_border = false;
  o.max_error_mm = 1e-6;  // only collapses that leave the surface where it was
  DecimationSummary s;
  const io::Mesh d = Decimate(m, o, &s);
  ASSERT_EQ(d.faces.size(), 2u);
  EXPECT_LT(s.error_mm, 1e-6);
  std::set<std::pair<float, float>> corners;
  for (const auto& p : d.vertices) {
    EXPECT_FLOAT_EQ(p.z(), 3.0f);
    corners.insert({p.x(), p.y()});
  }
  const float e = 1.5f * (n - 1);
  ASSERT_EQ(corners.size(), 4u);
  for (const auto& [cx, cy] : corners) {
    EXPECT_NEAR(std::min(cx, e - cx), 0.0f, 1e-5f);
    EXPECT_NEAR(std::min(cy, e - cy), 0.0f, 1e-5f);
  }
  EXPECT_NEAR(SurfaceAreaMm2(d), e * e, 1e-3);
}

TEST(Decimate, LockedBordersStayWhereTheyWere) {
  const int n = 21;
  const io::Mesh m = PlanarGrid(n);
  DecimationOptions o;
  o.target_triangles = 1;
  o.lock_border = true;
  const io::Mesh d = Decimate(m, o);
  // Every interior vertex goes; the 4 (n - 1) border vertices stay, exactly: a
  // triangulated polygon of 4 (n - 1) - 2 triangles covering the grid.
  EXPECT_EQ(d.vertices.size(), size_t(4 * (n - 1)));
  EXPECT_EQ(d.faces.size(), size_t(4 * (n - 1) - 2));
  std::set<std::pair<float, float>> border_in, out;
  for (const auto& p : m.vertices) {
    if (p.x() == 0 || p.y() == 0 || p.x() == 30 || p.y() == 30) border_in.insert({p.x(), p.y()});
  }
  for (const auto& p : d.vertices) {
    EXPECT_FLOAT_EQ(p.z(), 3.0f);
    out.insert({p.x(), p.y()});
  }
  EXPECT_EQ(out, border_in);
  EXPECT_NEAR(SurfaceAreaMm2(d), 900.0, 1e-3);
  EXPECT_EQ(AnalyzeTopology(d).boundary_edges, 4 * (n - 1));
}

TEST(Decimate, ErrorBoundStopsEarlyAndBordersStay) {
  auto v = testing::SphereVolume(40, 15.0);
  for (size_t n = 0; n < v.weight.size() / 2; ++n) v.weight[n] = 0;  // an open half sphere
  const io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  DecimationOptions o;
  o.target_ratio = 0.01;
  o.max_error_mm = 0.05;
  o.lock_border = true;
  DecimationSummary s;
  const io::Mesh d = Decimate(m, o, &s);
  EXPECT_GT(d.faces.size(), m.faces.size() / 100);
  EXPECT_LE(s.error_mm, 0.05);
  EXPECT_EQ(AnalyzeTopology(d).non_manifold_edges, 0);
  // Locked border: the border loop keeps all its vertices, in place.
  auto border_vertices = [](const io::Mesh& mesh) {
    std::map<std::pair<int, int>, int> uses;
    for (const auto& f : mesh.faces) {
      for (int k = 0; k < 3; ++k) ++uses[std::minmax(f[k], f[(k + 1) % 3])];
    }
    std::set<std::tuple<float, float, float>> out;
    for (const auto& [e, count] : uses) {
      if (count != 1) continue;
      for (int w : {e.first, e.second}) {
        const auto& p = mesh.vertices[w];
        out.insert({p.x(), p.y(), p.z()});
      }
    }
    return out;
  };
  const auto before = border_vertices(m);
  EXPECT_GT(before.size(), 50u);
  EXPECT_EQ(border_vertices(d), before);
}

// Colours linear in x stay linear in x: interpolated along the collapsed edges.
TEST(Decimate, ColoursAreInterpolated) {
  const auto v = testing::SphereVolume(40, 15.0);
  io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  auto red = [](const Eigen::Vector3f& p) { return 128.0 + 3.0 * p.x(); };  // 38..218
  for (const auto& p : m.vertices) {
    m.colors.push_back(io::Color3u8(uint8_t(std::lround(red(p))), 7, 200));
  }
  DecimationOptions o;
  o.target_ratio = 0.1;
  const io::Mesh d = Decimate(m, o);
  ASSERT_EQ(d.colors.size(), d.vertices.size());
  double worst = 0;
  for (size_t i = 0; i < d.vertices.size(); ++i) {
    worst = std::max(worst, std::abs(double(d.colors[i][0]) - red(d.vertices[i])));
    EXPECT_EQ(d.colors[i][1], 7);
    EXPECT_EQ(d.colors[i][2], 200);
  }
  EXPECT_LT(worst, 3.0);
}

// A sphere with floating bits around it: two lone triangles, a tetrahedron and a small
// sphere.
io::Mesh SphereWithFloaters(int64_t* sphere_faces) {
  const auto v = testing::SphereVolume(40, 15.0);
  io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  *sphere_faces = int64_t(m.faces.size());
  auto add = [&m](const std::vector<Eigen::Vector3f>& pts,
                  const std::vector<Eigen::Vector3i>& tris) {
    const int base = int(m.vertices.size());
    m.vertices.insert(m.vertices.end(), pts.begin(), pts.end());
    for (const auto& t : tris) m.faces.push_back(t + Eigen::Vector3i::Constant(base));
  };
  add({{60, 0, 0}, {62, 0, 0}, {60, 2, 0}}, {{0, 1, 2}});
  add({{0, 70, 0}, {0, 71, 0}, {0, 70, 1}}, {{0, 1, 2}});
  add({{0, 0, 80}, {3, 0, 80}, {0, 3, 80}, {0, 0, 83}},
      {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}});
  const auto small = testing::SphereVolume(8, 2.5);  // 5 mm radius
  io::Mesh s = MarchingCubes(small.grid, small.distance, small.weight);
  for (auto& p : s.vertices) p += Eigen::Vector3f(-70, 0, 0);
  add(s.vertices, s.faces);
  return m;
}

TEST(Decimate, SmallComponentsAreDroppedAndCounted) {
  int64_t sphere_faces = 0;
  const io::Mesh m = SphereWithFloaters(&sphere_faces);
  DecimationOptions o;
  o.target_ratio = 1.0;
  o.min_component_triangles = 10;
  DecimationSummary s;
  io::Mesh d = Decimate(m, o, &s);
  EXPECT_EQ(s.components_removed, 3);
  EXPECT_EQ(s.triangles_removed, 6);
  EXPECT_EQ(s.triangles_in, int64_t(m.faces.size()));
  // The small sphere (more than 10 triangles) stays; nothing else went.
  EXPECT_EQ(int64_t(d.faces.size()), int64_t(m.faces.size()) - 6);
  EXPECT_EQ(AnalyzeTopology(d).boundary_edges, 0);
  // By size: everything under a 20 mm diagonal goes, the small sphere included.
  o.min_component_triangles = 0;
  o.min_component_diagonal_mm = 20.0;
  d = Decimate(m, o, &s);
  EXPECT_EQ(s.components_removed, 4);
  EXPECT_EQ(int64_t(d.faces.size()), sphere_faces);
  for (const auto& p : d.vertices)
    EXPECT_NEAR((p.cast<double>() - kSphereCentre).norm(), 30.0, 0.1);
  // The dropped triangles count towards the target ratio.
  o.target_ratio = 0.5;
  d = Decimate(m, o, &s);
  EXPECT_EQ(int64_t(d.faces.size()), std::llround(0.5 * double(m.faces.size())) / 2 * 2);
}

TEST(Decimate, FreeBordersLetOpenFloatersShrink) {
  // Open parts (a strip of 40 triangles beside a sphere) shrink when borders are free;
  // their locked borders keep every vertex otherwise.
  int64_t sphere_faces = 0;
  io::Mesh m = SphereWithFloaters(&sphere_faces);
  const int base = int(m.vertices.size());
  for (int i = 0; i <= 20; ++i) {
    m.vertices.push_back(Eigen::Vector3f(50.0f + i, 40.0f, 0.0f));
    m.vertices.push_back(Eigen::Vector3f(50.0f + i, 41.0f, 0.0f));
  }
  for (int i = 0; i < 20; ++i) {
    const int a = base + 2 * i;
    m.faces.push_back(Eigen::Vector3i(a, a + 2, a + 3));
    m.faces.push_back(Eigen::Vector3i(a, a + 3, a + 1));
  }
  DecimationOptions o;
  o.target_triangles = 200;
  o.lock_border = false;
  o.max_error_mm = 1e-6;
  const io::Mesh d = Decimate(m, o);
  // The flat strip collapses to 2 triangles at no error; the lone triangles stay.
  int64_t strip = 0;
  for (const auto& f : d.faces)
    strip += std::abs(d.vertices[f[0]].y() - 40.5f) < 0.6f && d.vertices[f[0]].x() >= 50.0f;
  EXPECT_EQ(strip, 2);
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

// meshoptimizer's kept vertices moved to their quadric optimum put the coarse triangles
// across the curved surface instead of inside it: closer to the truth on average.
TEST(Decimate, MeshoptimizerRelocationBringsTheCoarseSurfaceCloser) {
  const auto v = testing::SphereVolume(60, 25.0);
  const io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  DecimationOptions o;
  o.method = DecimationMethod::kMeshoptimizer;
  o.target_ratio = 0.05;
  o.relocate_vertices = false;
  const io::Mesh kept = Decimate(m, o);
  o.relocate_vertices = true;
  const io::Mesh moved = Decimate(m, o);
  ASSERT_EQ(kept.faces.size(), moved.faces.size());
  const double e_kept = MeanSphereError(kept, kSphereCentre, 50.0),
               e_moved = MeanSphereError(moved, kSphereCentre, 50.0);
  EXPECT_LT(e_moved, 0.9 * e_kept) << e_kept << " -> " << e_moved;
  const MeshTopology t = AnalyzeTopology(moved);
  EXPECT_EQ(t.boundary_edges, 0);
  EXPECT_EQ(t.inconsistent_edges, 0);
}

// The meshoptimizer pass before the collapses: the exact target, a closed sphere, and
// the collapses after it, starting from the input's quadrics, end closer to the true
// sphere than meshoptimizer alone (its vertices stay input vertices).
TEST(Decimate, PrepassThenCollapsesReachTheTargetCloserThanMeshoptimizerAlone) {
  const auto v = testing::SphereVolume(60, 25.0);
  const io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  DecimationOptions o;
  o.target_ratio = 0.05;
  o.prepass_factor = 3.0;
  DecimationSummary summary;
  const io::Mesh both = Decimate(m, o, &summary);
  EXPECT_EQ(int64_t(both.faces.size()), summary.triangles_out);
  EXPECT_NEAR(double(both.faces.size()), 0.05 * double(m.faces.size()), 2.0);
  EXPECT_EQ(both.Inconsistency(), "");
  const MeshTopology t = AnalyzeTopology(both);
  EXPECT_EQ(t.boundary_edges, 0);
  EXPECT_EQ(t.non_manifold_edges, 0);
  EXPECT_EQ(EulerCharacteristic(both), 2);
  auto to_sphere = [](const Eigen::Vector3d& p) {
    return std::abs((p - kSphereCentre).norm() - 50);
  };
  EXPECT_LT(MaxDistanceToSurface(both, to_sphere), 0.5);
  DecimationOptions alone;
  alone.method = DecimationMethod::kMeshoptimizer;
  alone.target_triangles = int64_t(both.faces.size());
  alone.relocate_vertices = false;
  const io::Mesh coarse = Decimate(m, alone);
  EXPECT_LT(MeanSphereError(both, kSphereCentre, 50.0),
            0.9 * MeanSphereError(coarse, kSphereCentre, 50.0));
}

// A 30 mm sphere with `n` closed 5 mm spheres floating 10 mm off its surface (each with
// far more triangles than the small-component filter drops).
io::Mesh SphereWithSmallSpheres(int n, int64_t* sphere_faces) {
  const auto v = testing::SphereVolume(40, 15.0);
  io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  *sphere_faces = int64_t(m.faces.size());
  const auto small = testing::SphereVolume(8, 2.5);
  const io::Mesh s = MarchingCubes(small.grid, small.distance, small.weight);
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    const Eigen::Vector3f shift(float(45 * std::cos(a)), float(45 * std::sin(a)), 0.0f);
    const int base = int(m.vertices.size());
    for (const auto& p : s.vertices) m.vertices.push_back(p + shift);
    for (const auto& f : s.faces) m.faces.push_back(f + Eigen::Vector3i::Constant(base));
  }
  return m;
}

// Floaters each held at its last few triangles eat the budget; deleted whole, their
// triangles go to the main surface, which comes out closer to the truth.
TEST(Decimate, FloatersAreDeletedWholeWhenCheaperThanCollapsing) {
  int64_t sphere_faces = 0;
  const io::Mesh m = SphereWithSmallSpheres(12, &sphere_faces);
  ASSERT_GT(int64_t(m.faces.size()), sphere_faces + 12 * 20);
  DecimationOptions o;
  o.target_triangles = 200;
  o.component_deletion_factor = 0;
  DecimationSummary kept_summary, deleted_summary;
  const io::Mesh kept = Decimate(m, o, &kept_summary);
  o.component_deletion_factor = DecimationOptions().component_deletion_factor;
  const io::Mesh deleted = Decimate(m, o, &deleted_summary);
  EXPECT_EQ(kept_summary.components_deleted, 0);
  EXPECT_EQ(kept_summary.triangles_deleted, 0);
  EXPECT_EQ(deleted_summary.components_deleted, 12);
  EXPECT_GT(deleted_summary.triangles_deleted, 12 * 4 - 1);
  EXPECT_EQ(deleted_summary.components_removed, 0);  // the filters dropped nothing
  EXPECT_EQ(kept.faces.size(), 200u);
  EXPECT_EQ(deleted.faces.size(), 200u);
  // Everything left is the big sphere, closed, and closer to it than the sphere that had
  // to share its budget with the floaters.
  int64_t off_sphere = 0;
  for (const auto& p : kept.vertices) off_sphere += (p.cast<double>() - kSphereCentre).norm() > 35;
  EXPECT_GT(off_sphere, 12 * 3);
  for (const auto& p : deleted.vertices)
    EXPECT_NEAR((p.cast<double>() - kSphereCentre).norm(), 30.0, 1.5);
  EXPECT_EQ(AnalyzeTopology(deleted).boundary_edges, 0);
  io::Mesh kept_sphere = kept;
  kept_sphere.faces.clear();
  for (const auto& f : kept.faces) {
    if ((kept.vertices[f[0]].cast<double>() - kSphereCentre).norm() < 35) {
      kept_sphere.faces.push_back(f);
    }
  }
  EXPECT_LT(MeanSphereError(deleted, kSphereCentre, 30.0),
            0.8 * MeanSphereError(kept_sphere, kSphereCentre, 30.0));
  // An error bound below a deletion's estimate keeps the floaters.
  o.max_error_mm = 0.2;
  o.component_deletion_factor = 0.015;  // estimates of 0.015 * 17 mm diagonal = 0.26 mm
  DecimationSummary bounded;
  Decimate(m, o, &bounded);
  EXPECT_EQ(bounded.components_deleted, 0);
  o.max_error_mm = 0.0;
  Decimate(m, o, &bounded);
  EXPECT_GT(bounded.components_deleted, 0);
}

// Specks: small in area and extent, and apart from the parts that are not. Around a
// 30 mm sphere: 5 mm spheres 10 mm off its surface and one 0.3 mm off it; a long thin
// needle as small in area. The far small spheres go, counted with their triangles; the
// near one stays with a gap of 1.5 mm (and goes without one); the needle stays.
TEST(Decimate, SpecksAreSmallPartsAwayFromTheSurface) {
  int64_t sphere_faces = 0;
  io::Mesh m = SphereWithSmallSpheres(4, &sphere_faces);
  const int64_t four_faces = int64_t(m.faces.size()) - sphere_faces;
  const auto small = testing::SphereVolume(8, 2.5);
  const io::Mesh s = MarchingCubes(small.grid, small.distance, small.weight);
  // The near one: its surface 0.5 mm from the big sphere's (radius 30 about kSphereCentre).
  const Eigen::Vector3f near_shift(0.0f, 0.0f, 30.0f + 0.3f + 5.0f);
  int base = int(m.vertices.size());
  for (const auto& p : s.vertices) m.vertices.push_back(p + near_shift);
  for (const auto& f : s.faces) m.faces.push_back(f + Eigen::Vector3i::Constant(base));
  // The needle: 80 mm long, 0.2 mm wide, 50 mm below the sphere.
  base = int(m.vertices.size());
  for (int i = 0; i <= 40; ++i) {
    m.vertices.emplace_back(-40.0f + 2.0f * i, 0.0f, -80.0f);
    m.vertices.emplace_back(-40.0f + 2.0f * i, 0.2f, -80.0f);
  }
  for (int i = 0; i < 40; ++i) {
    const int v = base + 2 * i;
    m.faces.emplace_back(v, v + 2, v + 3);
    m.faces.emplace_back(v, v + 3, v + 1);
  }
  DecimationOptions o;
  o.target_ratio = 0.999;
  o.component_deletion_factor = 0;
  o.speck_area_fraction = 0.05;
  o.speck_diagonal_mm = 20;  // the small spheres are 17.3 mm across
  o.speck_gap_mm = 1.5;
  DecimationSummary with_gap;
  const io::Mesh d = Decimate(m, o, &with_gap);
  EXPECT_EQ(with_gap.specks_removed, 4);
  EXPECT_EQ(with_gap.speck_triangles, four_faces);
  float lowest = 1e9f;
  for (const auto& p : d.vertices) lowest = std::min(lowest, p.z());
  EXPECT_LT(lowest, -79.0f);  // the needle stays
  // The gap's queries are split over the threads: the same parts go on any count.
  for (int threads : {1, 3}) {
    o.num_threads = threads;
    DecimationSummary split;
    EXPECT_EQ(Decimate(m, o, &split).faces, d.faces) << threads;
    EXPECT_EQ(split.specks_removed, 4) << threads;
  }
  o.num_threads = 0;
  o.speck_gap_mm = 0;
  DecimationSummary without;
  Decimate(m, o, &without);
  EXPECT_EQ(without.specks_removed, 5);  // the near one too
  o.speck_area_fraction = 0;
  DecimationSummary off;
  Decimate(m, o, &off);
  EXPECT_EQ(off.specks_removed, 0);
  EXPECT_EQ(off.speck_triangles, 0);
}

// The component with the largest area is never deleted, however cheap the deletion.
TEST(Decimate, TheLargestComponentIsNeverDeleted) {
  int64_t sphere_faces = 0;
  const io::Mesh m = SphereWithSmallSpheres(1, &sphere_faces);
  DecimationOptions o;
  o.target_triangles = 20;
  o.component_deletion_factor = 1e-6;
  DecimationSummary s;
  const io::Mesh d = Decimate(m, o, &s);
  EXPECT_EQ(s.components_deleted, 1);
  EXPECT_EQ(d.faces.size(), 20u);
  // The coarse sphere's vertices sit outside it; the floater was 40..50 mm out.
  for (const auto& p : d.vertices) EXPECT_LT((p.cast<double>() - kSphereCentre).norm(), 36.0);
  // A deletion that would undershoot the target is skipped.
  o.target_triangles = sphere_faces + 10;
  const io::Mesh most = Decimate(m, o, &s);
  EXPECT_EQ(s.components_deleted, 0);
  EXPECT_EQ(int64_t(most.faces.size()), sphere_faces + 10);
}

// A comb on a gently curved sheet (z a paraboloid in x and y, mm): a 49 x 25 vertex grid
// at 1.5 mm with 3 mm wide, 30 mm deep slots between 9 mm wide teeth.
io::Mesh CurvedComb() {
  const int nx = 49, ny = 25;
  io::Mesh m;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const double x = 1.5 * i, y = 1.5 * j;
      m.vertices.push_back(
          Eigen::Vector3d(x, y, 0.01 * ((x - 36) * (x - 36) + (y - 18) * (y - 18))).cast<float>());
    }
  for (int j = 0; j + 1 < ny; ++j)
    for (int i = 0; i + 1 < nx; ++i) {
      if (i % 8 >= 6 && j >= 4) continue;  // a slot
      const int a = j * nx + i;
      m.faces.push_back(Eigen::Vector3i(a, a + 1, a + nx + 1));
      m.faces.push_back(Eigen::Vector3i(a, a + nx + 1, a + nx));
    }
  return m;
}

// The quadrics price a border vertex by its distance to the border's planes only, so a
// light border weight lets faces bridge the slots between the teeth, 1.5 mm from any
// input face at their middle. The deviation term makes such faces dear: the coarse comb
// keeps its slots open and stays within a fifth of that everywhere, whether the term
// counts from the first collapse or (the default) once within twice the target: the
// bridging faces come late, when the teeth are a few faces each.
TEST(Decimate, DeviationKeepsFacesFromBridgingGaps) {
  const io::Mesh m = CurvedComb();
  ASSERT_EQ(m.faces.size(), 1824u);
  auto to_input = [&m](const Eigen::Vector3d& p) { return DistanceToMesh(p, m); };
  DecimationOptions o;
  o.target_ratio = 0.05;
  const io::Mesh bounded = Decimate(m, o);
  o.deviation_from_factor = 0;
  const io::Mesh from_first = Decimate(m, o);
  o.deviation_weight = 0;
  const io::Mesh quadric_only = Decimate(m, o);
  EXPECT_NEAR(double(bounded.faces.size()), 91.0, 1.0);
  EXPECT_NEAR(double(from_first.faces.size()), 91.0, 1.0);
  EXPECT_LT(MaxDistanceToSurface(from_first, to_input), 0.5);
  EXPECT_NEAR(double(quadric_only.faces.size()), 91.0, 1.0);
  EXPECT_GT(MaxDistanceToSurface(quadric_only, to_input), 1.0);
  EXPECT_LT(MaxDistanceToSurface(bounded, to_input), 0.5);
  EXPECT_EQ(AnalyzeTopology(bounded).non_manifold_edges, 0);
}

// A sphere of radius 30 mm (about 8.6 k faces) with each vertex moved along its radius by
// up to +-0.3 mm (a fixed pseudo-random sequence), colours varying over it; with
// `floaters`, 24 octahedra of 1.5 mm radius 6 to 12 mm outside it.
io::Mesh NoisySphere(bool floaters) {
  const auto v = testing::SphereVolume(40, 15.0);
  io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  std::mt19937 rng(7);
  for (auto& p : m.vertices) {
    const Eigen::Vector3d d = p.cast<double>() - kSphereCentre;
    const double noise = 0.3 * (2.0 * double(rng()) / double(rng.max()) - 1.0);
    p = (kSphereCentre + d * (1.0 + noise / d.norm())).cast<float>();
    m.colors.push_back(
        Eigen::Vector3f(128 + d.x() * 3, 128 + d.y() * 3, 128 + d.z() * 3).cast<uint8_t>());
  }
  for (int i = 0; floaters && i < 24; ++i) {
    const double z = 1 - (i + 0.5) / 12.0, phi = i * 2.399963229728653, r = std::sqrt(1 - z * z);
    const Eigen::Vector3d c =
        kSphereCentre + (36.0 + i % 7) * Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), z);
    const int base = int(m.vertices.size());
    for (int k = 0; k < 6; ++k) {
      Eigen::Vector3d e = Eigen::Vector3d::Zero();
      e[k / 2] = k % 2 ? -1.5 : 1.5;
      m.vertices.push_back((c + e).cast<float>());
      m.colors.push_back(Eigen::Vector3f(200, 30, 30).cast<uint8_t>());
    }
    for (int sx : {0, 1})
      for (int sy : {2, 3})
        for (int sz : {4, 5}) {
          const bool flip = (sx + sy + sz) % 2 == 0;  // outward winding
          m.faces.push_back(flip ? Eigen::Vector3i(base + sx, base + sz, base + sy)
                                 : Eigen::Vector3i(base + sx, base + sy, base + sz));
        }
  }
  return m;
}

// Mean and largest distance of the points of `a` (vertices and face centroids) to `b`'s
// surface, mm (brute force).
std::pair<double, double> DistanceTo(const io::Mesh& a, const io::Mesh& b) {
  std::vector<Eigen::Vector3d> points;
  for (const auto& p : a.vertices) points.push_back(p.cast<double>());
  for (const auto& f : a.faces) {
    points.push_back((a.vertices[f[0]] + a.vertices[f[1]] + a.vertices[f[2]]).cast<double>() / 3);
  }
  double sum = 0, worst = 0;
  for (const auto& p : points) {
    const double best = DistanceToMesh(p, b);
    sum += best;
    worst = std::max(worst, best);
  }
  return {sum / double(points.size()), worst};
}

// The regions (their count from the face count only) give the same mesh, byte for byte,
// whatever the thread count; and they are used (the result is not the one pass's). 4
// regions are slices; 8 and 32 are boxes (their slices would put 39 % and 93 % of the
// sphere's faces on seams), both with the second round, which cuts 3 and 9 slices.
TEST(Decimate, RegionsGiveTheSameMeshOnAnyThreadCount) {
  const io::Mesh m = NoisySphere(/*floaters=*/true);
  ASSERT_GT(m.faces.size(), 8000u);
  DecimationOptions o;
  o.target_ratio = 0.1;
  o.faces_per_region = 0;
  const io::Mesh one_pass = Decimate(m, o);
  for (int64_t regions : {4, 8, 32}) {
    o.faces_per_region = int64_t(m.faces.size()) / (regions + 1);
    std::vector<io::Mesh> out;
    for (int threads : {1, 2, 4}) {
      o.num_threads = threads;
      out.push_back(Decimate(m, o));
    }
    for (size_t i = 1; i < out.size(); ++i) {
      EXPECT_EQ(out[i].vertices, out[0].vertices) << regions << " regions, " << i;
      EXPECT_EQ(out[i].colors, out[0].colors) << regions << " regions, " << i;
      EXPECT_EQ(out[i].faces, out[0].faces) << regions << " regions, " << i;
    }
    EXPECT_EQ(one_pass.faces.size(), out[0].faces.size()) << regions;
    EXPECT_NE(one_pass.vertices, out[0].vertices) << regions;
  }
}

// Cut in 4 slices, or in 16 boxes (16 slices would put 76 % of its faces on seams) and
// the second round's 5 slices, a closed sphere stays closed:
// the seams are joined with no border, non-manifold or inconsistently wound edge, the
// Euler characteristic stays 2, and the pass over the joined regions reaches the exact
// count.
TEST(Decimate, RegionSeamsStayWatertightAndTheCountIsExact) {
  const io::Mesh m = NoisySphere(/*floaters=*/false);
  ASSERT_EQ(AnalyzeTopology(m).boundary_edges, 0);
  ASSERT_EQ(EulerCharacteristic(m), 2);
  const std::pair<int64_t, int64_t> cases[] = {{2000, 4}, {600, 4}, {2000, 16}};
  for (const auto& [target, regions] : cases) {
    DecimationOptions o;
    o.faces_per_region = int64_t(m.faces.size()) / (regions + 1);
    o.target_triangles = target;
    DecimationSummary s;
    const io::Mesh d = Decimate(m, o, &s);
    EXPECT_EQ(int64_t(d.faces.size()), target);
    EXPECT_EQ(s.triangles_out, target);
    EXPECT_EQ(d.Inconsistency(), "");
    const MeshTopology t = AnalyzeTopology(d);
    EXPECT_EQ(t.boundary_edges, 0) << target;
    EXPECT_EQ(t.non_manifold_edges, 0) << target;
    EXPECT_EQ(t.inconsistent_edges, 0) << target;
    EXPECT_EQ(EulerCharacteristic(d), 2) << target;
  }
}

// At 10% of the noisy sphere with floaters, 8 regions (boxes, and the second round's 3
// slices) stay as
// close to the input as one pass (mean and largest distance both ways, the sphere's,
// within 10%), delete the floaters too, and keep to an error bound.
TEST(Decimate, RegionsStayAsCloseToTheInputAsOnePass) {
  const io::Mesh m = NoisySphere(/*floaters=*/true), sphere = NoisySphere(/*floaters=*/false);
  DecimationOptions o;
  o.target_ratio = 0.1;
  DecimationSummary one_s, regions_s;
  o.faces_per_region = 0;
  const io::Mesh one = Decimate(m, o, &one_s);
  o.faces_per_region = int64_t(m.faces.size()) / 9;
  const io::Mesh regions = Decimate(m, o, &regions_s);
  const auto one_to = DistanceTo(one, sphere), one_from = DistanceTo(sphere, one);
  const auto reg_to = DistanceTo(regions, sphere), reg_from = DistanceTo(sphere, regions);
  EXPECT_LT(reg_to.first, 1.1 * one_to.first);
  EXPECT_LT(reg_to.second, 1.1 * one_to.second);
  EXPECT_LT(reg_from.first, 1.1 * one_from.first);
  EXPECT_LT(reg_from.second, 1.1 * one_from.second);
  EXPECT_EQ(one_s.components_deleted, 24);
  EXPECT_EQ(regions_s.components_deleted, 24);
  // The error bound holds in the regions and in the pass over them: it stops early.
  o.max_error_mm = 0.25;
  DecimationSummary bounded;
  Decimate(m, o, &bounded);
  EXPECT_GT(bounded.error_mm, 0.0);
  EXPECT_LE(bounded.error_mm, 0.25);
  EXPECT_GT(bounded.triangles_out, regions_s.triangles_out);
  std::printf("one pass: to %.4f / %.4f mm, from %.4f / %.4f mm, error %.4f\n", one_to.first,
              one_to.second, one_from.first, one_from.second, one_s.error_mm);
  std::printf("regions:  to %.4f / %.4f mm, from %.4f / %.4f mm, error %.4f\n", reg_to.first,
              reg_to.second, reg_from.first, reg_from.second, regions_s.error_mm);
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
  o.target_triangles = -5;
  testing::ExpectInputError([&] { Decimate(m, o); }, {"decimation: target_triangles", "-5"});
  o = {};
  o.border_weight = -1;
  testing::ExpectInputError([&] { Decimate(m, o); }, {"decimation: border_weight"});
  o = {};
  o.deviation_weight = -2;
  testing::ExpectInputError([&] { Decimate(m, o); }, {"decimation: deviation_weight", "-2"});
  o = {};
  o.deviation_from_factor = 0.5;
  testing::ExpectInputError([&] { Decimate(m, o); },
                            {"decimation: deviation_from_factor", "0.5", ">= 1"});
  o = {};
  o.min_component_triangles = -1;
  testing::ExpectInputError([&] { Decimate(m, o); }, {"decimation: min_component_triangles"});
  o = {};
  o.min_component_diagonal_mm = std::nan("");
  testing::ExpectInputError([&] { Decimate(m, o); }, {"decimation: min_component_diagonal_mm"});
  o = {};
  o.component_deletion_factor = -0.5;
  testing::ExpectInputError([&] { Decimate(m, o); },
                            {"decimation: component_deletion_factor", "-0.5"});
  o.component_deletion_factor = std::nan("");
  testing::ExpectInputError([&] { Decimate(m, o); }, {"decimation: component_deletion_factor"});
  o = {};
  o.prepass_factor = 1.0;
  testing::ExpectInputError([&] { Decimate(m, o); }, {"decimation: prepass_factor", "> 1"});
  o = {};
  o.speck_area_fraction = 1.5;
  testing::ExpectInputError([&] { Decimate(m, o); }, {"decimation: speck_area_fraction"});
  o = {};
  o.speck_gap_mm = -1;
  testing::ExpectInputError([&] { Decimate(m, o); }, {"decimation: speck_gap_mm"});
  o = {};
  o.faces_per_region = -1;
  testing::ExpectInputError([&] { Decimate(m, o); }, {"decimation: faces_per_region", "-1"});
  o = {};
  m.vertices.push_back(Eigen::Vector3f::Zero());
  m.faces.push_back(Eigen::Vector3i(0, 1, 2));
  testing::ExpectInputError([&] { Decimate(m, o); }, {"decimation: mesh"});
}

}  // namespace
}  // namespace dome::mesh
