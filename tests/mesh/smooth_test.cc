// Taubin smoothing (mesh/smooth.h): noise off a sphere without shrinking it, planes kept
// planar, nothing moved at 0 iterations, options named.
#include "mesh/smooth.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>

#include "mesh/marching_cubes.h"
#include "mesh/mesh_test_util.h"
#include "testing/expect_error.h"

namespace dome::mesh {
namespace {

const Eigen::Vector3d kCentre(0.173, -0.291, 0.117);  // SphereVolume's centre, mm
constexpr double kRadiusMm = 50.0;                    // 25 voxels of 2 mm

struct RadialStats {
  double mean = 0, rms = 0;  // of (|v - centre| - radius), mm
};

RadialStats Radial(const io::Mesh& m) {
  RadialStats s;
  for (const auto& v : m.vertices) {
    const double e = (v.cast<double>() - kCentre).norm() - kRadiusMm;
    s.mean += e;
    s.rms += e * e;
  }
  s.mean /= double(m.vertices.size());
  s.rms = std::sqrt(s.rms / double(m.vertices.size()));
  return s;
}

io::Mesh NoisySphere(double sigma_mm) {
  const auto v = testing::SphereVolume(60, 25.0);
  io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, sigma_mm);
  for (auto& p : m.vertices) {
    const Eigen::Vector3d d = (p.cast<double>() - kCentre).normalized();
    p += (d * noise(rng)).cast<float>();
  }
  return m;
}

TEST(Smooth, TakesNoiseOffASphereWithoutShrinkingIt) {
  io::Mesh m = NoisySphere(0.4);  // a fifth of a voxel
  const RadialStats before = Radial(m);
  ASSERT_GT(before.rms, 0.35);
  SmoothOptions o;
  o.iterations = 10;
  SmoothTaubin(o, &m);
  const RadialStats after = Radial(m);
  // 0.40 -> 0.15 mm here.
  EXPECT_LT(after.rms, before.rms / 2.5) << before.rms << " -> " << after.rms;
  EXPECT_LT(std::abs(after.mean), 0.02) << after.mean;  // the radius is kept
  EXPECT_EQ(m.faces.size(), NoisySphere(0.4).faces.size());
}

TEST(Smooth, APlaneStaysInItsPlane) {
  // A 20 x 20 grid of vertices at z = 3 with jittered x, y: open borders all round.
  io::Mesh m;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> jitter(-0.3f, 0.3f);
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 20; ++x) m.vertices.emplace_back(x + jitter(rng), y + jitter(rng), 3.0f);
  for (int y = 0; y + 1 < 20; ++y) {
    for (int x = 0; x + 1 < 20; ++x) {
      const int a = y * 20 + x;
      m.faces.emplace_back(a, a + 1, a + 21);
      m.faces.emplace_back(a, a + 21, a + 20);
    }
  }
  SmoothOptions o;
  o.iterations = 5;
  const io::Mesh before = m;
  SmoothTaubin(o, &m);
  double moved = 0;
  for (size_t i = 0; i < m.vertices.size(); ++i) {
    EXPECT_EQ(m.vertices[i].z(), 3.0f) << i;
    moved = std::max(moved, double((m.vertices[i] - before.vertices[i]).norm()));
  }
  EXPECT_GT(moved, 0.01);  // the jitter is smoothed within the plane
}

TEST(Smooth, NoIterationsLeaveTheMeshAsItIs) {
  io::Mesh m = NoisySphere(0.4);
  const io::Mesh before = m;
  SmoothTaubin(SmoothOptions{}, &m);
  ASSERT_EQ(m.vertices.size(), before.vertices.size());
  for (size_t i = 0; i < m.vertices.size(); ++i) ASSERT_EQ(m.vertices[i], before.vertices[i]);
}

// The lambda|mu steps as the header states them, written plainly: each vertex moves
// towards the mean of its edge neighbours taken in ascending index order.
std::vector<Eigen::Vector3f> PlainTaubin(const io::Mesh& mesh, const SmoothOptions& o) {
  std::vector<std::set<int>> nbr(mesh.vertices.size());
  for (const auto& f : mesh.faces) {
    for (int k = 0; k < 3; ++k) {
      nbr[size_t(f[k])].insert(f[(k + 1) % 3]);
      nbr[size_t(f[(k + 1) % 3])].insert(f[k]);
    }
  }
  std::vector<Eigen::Vector3d> p;
  for (const auto& v : mesh.vertices) p.push_back(v.cast<double>());
  for (int i = 0; i < 2 * o.iterations; ++i) {
    const double factor = i % 2 == 0 ? o.lambda : o.mu;
    std::vector<Eigen::Vector3d> next = p;
    for (size_t v = 0; v < p.size(); ++v) {
      if (nbr[v].empty()) continue;
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (int n : nbr[v]) mean += p[size_t(n)];
      next[v] = p[v] + factor * (mean / double(nbr[v].size()) - p[v]);
    }
    p = next;
  }
  std::vector<Eigen::Vector3f> out;
  for (const auto& v : p) out.push_back(v.cast<float>());
  return out;
}

// The vertices are split over threads: the same bits on any number of them, and the
// bits of the plain steps above (nothing on a noisy sphere is short enough to weld).
TEST(Smooth, TheSameBitsOnAnyNumberOfThreads) {
  const io::Mesh input = NoisySphere(0.4);
  SmoothOptions o;
  o.iterations = 3;
  const std::vector<Eigen::Vector3f> plain = PlainTaubin(input, o);
  for (int threads : {1, 2, 3}) {
    io::Mesh m = input;
    o.num_threads = threads;
    SmoothTaubin(o, &m);
    ASSERT_EQ(m.vertices.size(), plain.size()) << threads;
    for (size_t i = 0; i < plain.size(); ++i)
      ASSERT_EQ(m.vertices[i], plain[i]) << threads << " threads, vertex " << i;
  }
}

TEST(Smooth, BadOptionsAreNamed) {
  io::Mesh m = NoisySphere(0.1);
  SmoothOptions o;
  o.iterations = -2;
  dome::testing::ExpectInputError([&] { SmoothTaubin(o, &m); }, {"smooth_iterations", "-2"});
  o = {};
  o.lambda = 1.5;
  dome::testing::ExpectInputError([&] { SmoothTaubin(o, &m); }, {"smooth_lambda"});
  o = {};
  o.mu = -0.4;  // not an inflation larger than the shrink: the mesh would shrink
  dome::testing::ExpectInputError([&] { SmoothTaubin(o, &m); }, {"smooth_mu"});
  o = {};
  o.num_threads = -1;
  dome::testing::ExpectInputError([&] { SmoothTaubin(o, &m); }, {"num_threads", "-1"});
}

// Edges shorter than the limit are welded: their ends become one vertex (the least index
// keeps its position and colour), the faces that lose their area go, and the vertices are
// renumbered in order.
TEST(WeldShortEdges, MergesTheEndsOfShortEdgesAndDropsTheFacesThatCollapse) {
  io::Mesh m;
  m.vertices = {{0, 0, 0},         {1, 0, 0}, {1, 1, 0},         {0, 1, 0},
                {1, 1 + 1e-5f, 0}, {5, 5, 5}, {5 + 1e-5f, 5, 5}, {5, 5 + 1e-5f, 5}};
  for (size_t v = 0; v < m.vertices.size(); ++v) m.colors.push_back(io::Color3u8(uint8_t(v), 0, 0));
  // A square, a needle beside it (vertex 4 on top of 2) and a speck (5, 6, 7).
  m.faces = {{0, 1, 2}, {0, 2, 3}, {2, 4, 3}, {5, 6, 7}};
  // A vertex without faces from the start stays.
  m.vertices.push_back({9, 9, 9});
  m.colors.push_back(io::Color3u8(8, 0, 0));
  EXPECT_EQ(WeldShortEdges(1e-3, &m), 2);
  EXPECT_EQ(m.Inconsistency(), "");
  ASSERT_EQ(m.vertices.size(), 5u);  // the square's 4 and the lone vertex; the speck is gone
  EXPECT_EQ(m.faces.size(), 2u);
  EXPECT_EQ(m.faces[0], Eigen::Vector3i(0, 1, 2));
  EXPECT_EQ(m.faces[1], Eigen::Vector3i(0, 2, 3));
  EXPECT_EQ(m.vertices[2], Eigen::Vector3f(1, 1, 0));
  EXPECT_EQ(m.vertices[4], Eigen::Vector3f(9, 9, 9));
  EXPECT_EQ(m.colors[3], io::Color3u8(3, 0, 0));
  EXPECT_EQ(m.colors[4], io::Color3u8(8, 0, 0));
  // Nothing shorter than the limit: nothing changes.
  const io::Mesh before = m;
  EXPECT_EQ(WeldShortEdges(1e-3, &m), 0);
  EXPECT_EQ(m.vertices, before.vertices);
  EXPECT_EQ(m.faces, before.faces);
}

// A small separate piece has all its vertices on its border, so smoothing draws it to a
// point; its faces must not stay behind without area. The sphere beside it keeps every
// face.
TEST(Smooth, LeavesNoFaceWithoutArea) {
  io::Mesh m = NoisySphere(0.0);
  const size_t sphere_faces = m.faces.size();
  const int n = int(m.vertices.size());
  // A 0.2 mm triangle (a tenth of a voxel) far from the sphere.
  m.vertices.push_back({200.0f, 0, 0});
  m.vertices.push_back({200.2f, 0, 0});
  m.vertices.push_back({200.1f, 0.17f, 0});
  m.faces.push_back({n, n + 1, n + 2});
  SmoothOptions o;
  o.iterations = 15;
  SmoothTaubin(o, &m);
  EXPECT_EQ(m.faces.size(), sphere_faces);
  EXPECT_EQ(m.Inconsistency(), "");
  EXPECT_GT(testing::LeastFaceArea(m), 1e-3);  // mm^2; the sphere's faces are about 1 mm^2
  EXPECT_EQ(m.vertices.size(), size_t(n));     // the speck's vertices went with it
}

}  // namespace
}  // namespace dome::mesh
