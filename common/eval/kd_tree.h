// Exact nearest-neighbour queries over a fixed 3D point set.
//
// A median-split k-d tree (Bentley 1975; Friedman, Bentley & Finkel 1977): each
// inner node splits its points at the median of the coordinate with the largest
// extent, leaves hold a few points stored contiguously. Queries are exact and
// read-only, so any number of threads may query one tree concurrently. Coordinates
// are whatever the caller uses (eval passes millimetres).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <vector>

namespace dome::eval {

class PointKdTree {
 public:
  struct Neighbor {
    int64_t index = -1;  // into the points given to the constructor; -1 when none
    float distance_sq = std::numeric_limits<float>::infinity();
  };

  // Copies the points; at most 2^31 - 1 of them.
  explicit PointKdTree(const std::vector<Eigen::Vector3f>& points, int leaf_size = 8);

  int64_t size() const { return static_cast<int64_t>(index_.size()); }

  // The nearest point to `query`, skipping the point whose index is `exclude` (pass
  // the query's own index to get its nearest *other* point, like cKDTree's k=2).
  // Returns index -1 only for an empty tree (or a one-point tree excluding it).
  Neighbor Nearest(const Eigen::Vector3f& query, int64_t exclude = -1) const;

 private:
  struct Node {
    float split = 0.0f;
    int32_t dim = -1;  // -1: leaf over [begin, end) of points_
    int32_t begin = 0, end = 0;
    int32_t left = -1, right = -1;
  };

  int32_t Build(int32_t begin, int32_t end, int leaf_size);
  void Search(int32_t node, const Eigen::Vector3f& q, int64_t exclude, Neighbor& best) const;

  std::vector<Eigen::Vector3f> points_;  // permuted into leaf order
  std::vector<int32_t> index_;           // original index of points_[i]
  std::vector<Node> nodes_;
};

}  // namespace dome::eval
