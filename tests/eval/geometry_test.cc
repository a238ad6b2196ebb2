// Geometry kernels of eval: point-to-triangle distance, BVH, k-d tree, surface
// sampling, quantiles.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "eval/kd_tree.h"
#include "eval/statistics.h"
#include "eval/surface_sampling.h"
#include "eval/triangle_bvh.h"

namespace dome::eval {
namespace {

using Eigen::Vector3d;
using Eigen::Vector3f;

TEST(PointTriangleDistance, HandValuesInEveryRegion) {
  const Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_DOUBLE_EQ(PointTriangleDistance({0.2, 0.2, 3}, a, b, c), 3.0);             // face
  EXPECT_DOUBLE_EQ(PointTriangleDistance({0.2, 0.2, -0.5}, a, b, c), 0.5);          // face, below
  EXPECT_DOUBLE_EQ(PointTriangleDistance({0.25, 0.25, 0}, a, b, c), 0.0);           // on it
  EXPECT_DOUBLE_EQ(PointTriangleDistance({-1, -1, 1}, a, b, c), std::sqrt(3.0));    // vertex a
  EXPECT_DOUBLE_EQ(PointTriangleDistance({3, 0, 0}, a, b, c), 2.0);                 // vertex b
  EXPECT_DOUBLE_EQ(PointTriangleDistance({-0.5, 2, 0}, a, b, c), std::sqrt(1.25));  // vertex c
  EXPECT_DOUBLE_EQ(PointTriangleDistance({0.5, -1, 0}, a, b, c), 1.0);              // edge ab
  EXPECT_DOUBLE_EQ(PointTriangleDistance({-2, 0.5, 1}, a, b, c), std::sqrt(5.0));   // edge ac
  EXPECT_NEAR(PointTriangleDistance({1, 1, 0}, a, b, c), std::sqrt(0.5), 1e-15);    // edge bc
  EXPECT_NEAR(PointTriangleDistance({1, 1, 2}, a, b, c), std::sqrt(4.5), 1e-15);  // edge bc, above
  EXPECT_LT((ClosestPointOnTriangle({0.2, 0.3, 7}, a, b, c) - Vector3d(0.2, 0.3, 0)).norm(), 1e-15);
}

TEST(PointTriangleDistance, DegenerateTrianglesAreTheirEdges) {
  // Collinear: the segment from (0,0,0) to (2,0,0).
  EXPECT_DOUBLE_EQ(PointTriangleDistance({1, 1, 0}, {0, 0, 0}, {1, 0, 0}, {2, 0, 0}), 1.0);
  EXPECT_DOUBLE_EQ(PointTriangleDistance({3, 0, 0}, {0, 0, 0}, {2, 0, 0}, {1, 0, 0}), 1.0);
  // Two equal vertices.
  EXPECT_DOUBLE_EQ(PointTriangleDistance({0.5, 2, 0}, {0, 0, 0}, {0, 0, 0}, {1, 0, 0}), 2.0);
  // All three equal: a point.
  EXPECT_DOUBLE_EQ(PointTriangleDistance({0, 3, 4}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}), 5.0);
}

double BruteForceDistance(const std::vector<Vector3f>& v, const std::vector<Eigen::Vector3i>& f,
                          const Vector3d& q) {
  double best = INFINITY;
  for (const auto& t : f) {
    best = std::min(best, PointTriangleDistance(q, v[t[0]].cast<double>(), v[t[1]].cast<double>(),
                                                v[t[2]].cast<double>()));
  }
  return best;
}

TEST(TriangleBvh, MatchesBruteForce) {
  std::mt19937 gen(3);
  std::uniform_real_distribution<float> u(-10.0f, 10.0f);
  std::vector<Vector3f> v;
  std::vector<Eigen::Vector3i> f;
  for (int i = 0; i < 600; ++i) {
    const Vector3f centre(u(gen), u(gen), u(gen));
    const int base = static_cast<int>(v.size());
    for (int k = 0; k < 3; ++k) {
      v.push_back(centre + 0.2f * Vector3f(u(gen), u(gen), u(gen)));
    }
    f.emplace_back(base, base + 1, base + 2);
  }
  f.emplace_back(0, 0, 1);  // a degenerate one too
  const TriangleBvh bvh(v, f);
  EXPECT_EQ(bvh.num_triangles(), 601);
  for (int i = 0; i < 300; ++i) {
    const Vector3d q(1.5 * u(gen), 1.5 * u(gen), 1.5 * u(gen));
    const TriangleBvh::Hit hit = bvh.Closest(q);
    EXPECT_NEAR(std::sqrt(hit.distance_sq), BruteForceDistance(v, f, q), 1e-12);
    EXPECT_NEAR((hit.point - q).squaredNorm(), hit.distance_sq, 1e-9);
  }
  EXPECT_EQ(TriangleBvh(v, {}).Closest(Vector3d::Zero()).face, -1);
}

TEST(PointKdTree, MatchesBruteForceAndExcludes) {
  std::mt19937 gen(5);
  std::uniform_real_distribution<float> u(-50.0f, 50.0f);
  std::vector<Vector3f> points;
  points.reserve(5001);
  for (int i = 0; i < 5000; ++i) {
    points.emplace_back(u(gen), u(gen), 0.1f * u(gen));
  }
  points.push_back(points[17]);  // a duplicate: its nearest other point is at 0
  const PointKdTree tree(points);
  for (int i = 0; i < 500; ++i) {
    const Vector3f q(u(gen), u(gen), u(gen));
    float best = INFINITY;
    for (const auto& p : points) {
      best = std::min(best, (p - q).squaredNorm());
    }
    const auto n = tree.Nearest(q);
    EXPECT_EQ(n.distance_sq, best);
    EXPECT_EQ((points[n.index] - q).squaredNorm(), best);
  }
  for (int i : {0, 17, 1234, 4999}) {
    const auto n = tree.Nearest(points[i], i);
    EXPECT_NE(n.index, i);
    float best = INFINITY;
    for (size_t j = 0; j < points.size(); ++j) {
      if (static_cast<int>(j) != i) {
        best = std::min(best, (points[j] - points[i]).squaredNorm());
      }
    }
    EXPECT_EQ(n.distance_sq, best);
  }
  EXPECT_EQ(tree.Nearest(points[17], 17).distance_sq, 0.0f);
  EXPECT_EQ(PointKdTree({}).Nearest(Vector3f::Zero()).index, -1);
}

TEST(SurfaceSampling, UniformByAreaDeterministicAndThreadIndependent) {
  // Two triangles of areas 2 and 6 (a 1:3 split), in different planes.
  const std::vector<Vector3f> v = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0},
                                   {0, 0, 5}, {6, 0, 5}, {0, 2, 5}};
  const std::vector<Eigen::Vector3i> f = {{0, 1, 2}, {3, 4, 5}};
  EXPECT_DOUBLE_EQ(SurfaceArea(v, f), 8.0);
  const auto a = SampleSurfaceUniformly(v, f, 200000, 42, 1);
  const auto b = SampleSurfaceUniformly(v, f, 200000, 42, 4);
  ASSERT_EQ(a.size(), 200000u);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, SampleSurfaceUniformly(v, f, 200000, 43, 1));
  int upper = 0;
  double mean_x_lower = 0.0;
  for (const auto& p : a) {
    if (p.z() == 5.0f) {
      ++upper;
      EXPECT_LE(p.x() / 6.0f + p.y() / 2.0f, 1.0f + 1e-6f);
    } else {
      ASSERT_EQ(p.z(), 0.0f);
      EXPECT_LE(p.x() + p.y(), 2.0f + 1e-6f);
      mean_x_lower += p.x();
    }
  }
  EXPECT_EQ(upper, 150000);  // stratified: exactly the area share
  // The centroid of a uniform triangle sample is the triangle's centroid (x = 2/3).
  EXPECT_NEAR(mean_x_lower / (200000 - upper), 2.0 / 3.0, 0.01);
  EXPECT_TRUE(SampleSurfaceUniformly(v, {{0, 0, 1}}, 10, 1).empty());  // no area
}

TEST(Statistics, QuantilesLikeNumpy) {
  std::vector<double> v = {4, 1, 3, 2};
  EXPECT_DOUBLE_EQ(Quantile(v, 0.5), 2.5);  // numpy.median([1,2,3,4])
  EXPECT_DOUBLE_EQ(Quantile(v, 0.9), 3.7);  // numpy.percentile(.., 90)
  EXPECT_DOUBLE_EQ(Quantile(v, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(Quantile(v, 1.0), 4.0);
  std::vector<double> odd = {5, 1, 3};
  EXPECT_DOUBLE_EQ(Quantile(odd, 0.5), 3.0);
  std::vector<double> empty;
  EXPECT_TRUE(std::isnan(Quantile(empty, 0.5)));
  EXPECT_DOUBLE_EQ(Mean({1, 2, 6}), 3.0);
  EXPECT_DOUBLE_EQ(FractionAtMost({1, 2, 3, 4}, 2.0), 0.5);
}

}  // namespace
}  // namespace dome::eval
