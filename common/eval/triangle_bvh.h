// Exact point-to-triangle-mesh distance queries.
//
// ClosestPointOnTriangle follows Ericson, "Real-Time Collision Detection" (2005),
// §5.1.5 (Voronoi regions of the vertices, edges and face), in double precision;
// degenerate (zero-area) triangles, which marching cubes does emit, are handled as
// their edges so they never produce NaN. TriangleBvh is a bounding-volume hierarchy
// (axis-aligned boxes, median split of triangle centroids along the longest axis)
// searched nearest-box-first with pruning by box distance, so a query touches a
// handful of leaves. Queries are read-only and thread-safe.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <vector>

namespace dome::eval {

// The point of triangle (a, b, c) nearest to p.
Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                       const Eigen::Vector3d& b, const Eigen::Vector3d& c);

// Euclidean distance from p to triangle (a, b, c).
double PointTriangleDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                             const Eigen::Vector3d& b, const Eigen::Vector3d& c);

class TriangleBvh {
 public:
  struct Hit {
    int64_t face = -1;  // -1 when the mesh has no triangles
    double distance_sq = std::numeric_limits<double>::infinity();
    Eigen::Vector3d point = Eigen::Vector3d::Zero();  // closest point on the mesh
  };

  // Copies the triangles; face indices must be valid for `vertices` (DOME_CHECK).
  TriangleBvh(const std::vector<Eigen::Vector3f>& vertices,
              const std::vector<Eigen::Vector3i>& faces);

  int64_t num_triangles() const { return static_cast<int64_t>(triangles_.size()); }

  // The nearest point of the mesh to `query`.
  Hit Closest(const Eigen::Vector3d& query) const;

 private:
  struct Triangle {
    Eigen::Vector3f a, b, c;
    int32_t face;
  };
  struct Node {
    Eigen::Vector3f lo, hi;
    int32_t left = -1, right = -1;  // -1: leaf over [begin, end) of triangles_
    int32_t begin = 0, end = 0;
  };

  int32_t Build(int32_t begin, int32_t end, const std::vector<Triangle>& input,
                const std::vector<Eigen::Vector3f>& centroids, std::vector<int32_t>& order);
  void Search(int32_t node, const Eigen::Vector3d& q, Hit& best) const;
  double BoxDistanceSq(const Node& node, const Eigen::Vector3d& q) const;

  std::vector<Triangle> triangles_;
  std::vector<Node> nodes_;
};

}  // namespace dome::eval
