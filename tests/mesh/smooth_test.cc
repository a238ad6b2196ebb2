// Taubin smoothing (mesh/smooth.h): noise off a sphere without shrinking it, planes kept
// planar, nothing moved at 0 iterations, options named.
#include "mesh/smooth.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mesh/marching_cubes.h"
#include "mesh/mesh_test_util.h"
#include "testing/expect_error.h"

namespace dome::mesh {
namespace {

const Eigen::Vector3d kCentre(0.173, -0.291, 0.117);  // SphereVolume's centre, mm
constexpr double kRadiusMm = 50.0;                     // 25 voxels of 2 mm

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
}

}  // namespace
}  // namespace dome::mesh
