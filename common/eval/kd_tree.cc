#include "eval/kd_tree.h"

#include <algorithm>
#include <numeric>

#include "core/error.h"

namespace dome::eval {

PointKdTree::PointKdTree(const std::vector<Eigen::Vector3f>& points, int leaf_size) {
  DOME_CHECK(points.size() < static_cast<size_t>(std::numeric_limits<int32_t>::max()),
             "PointKdTree: too many points");
  DOME_CHECK(leaf_size >= 1, "PointKdTree: leaf_size must be positive");
  index_.resize(points.size());
  std::iota(index_.begin(), index_.end(), 0);
  points_ = points;
  if (points.empty()) {
    return;
  }
  nodes_.reserve(2 * points.size() / leaf_size + 1);
  Build(0, static_cast<int32_t>(points.size()), leaf_size);
  // Leaf order makes a leaf's points contiguous in memory for the query loop.
  for (size_t i = 0; i < index_.size(); ++i) {
    points_[i] = points[index_[i]];
  }
}

int32_t PointKdTree::Build(int32_t begin, int32_t end, int leaf_size) {
  const int32_t id = static_cast<int32_t>(nodes_.size());
  nodes_.emplace_back();
  if (end - begin <= leaf_size) {
    nodes_[id].begin = begin;
    nodes_[id].end = end;
    return id;
  }
  Eigen::Vector3f lo = points_[index_[begin]], hi = lo;
  for (int32_t i = begin + 1; i < end; ++i) {
    lo = lo.cwiseMin(points_[index_[i]]);
    hi = hi.cwiseMax(points_[index_[i]]);
  }
  int dim = 0;
  (hi - lo).maxCoeff(&dim);
  const int32_t mid = begin + (end - begin) / 2;
  std::nth_element(index_.begin() + begin, index_.begin() + mid, index_.begin() + end,
                   [&](int32_t a, int32_t b) { return points_[a][dim] < points_[b][dim]; });
  const float split = points_[index_[mid]][dim];
  const int32_t left = Build(begin, mid, leaf_size);
  const int32_t right = Build(mid, end, leaf_size);
  Node& node = nodes_[id];  // re-fetch: Build may have grown nodes_
  node.dim = dim;
  node.split = split;
  node.left = left;
  node.right = right;
  return id;
}

void PointKdTree::Search(int32_t id, const Eigen::Vector3f& q, int64_t exclude,
                         Neighbor& best) const {
  const Node& node = nodes_[id];
  if (node.dim < 0) {
    for (int32_t i = node.begin; i < node.end; ++i) {
      const float d2 = (points_[i] - q).squaredNorm();
      if (d2 < best.distance_sq && index_[i] != exclude) {
        best.distance_sq = d2;
        best.index = index_[i];
      }
    }
    return;
  }
  // Points equal to the split value may sit on either side (nth_element), so the
  // far side is visited whenever the slab distance does not exceed the best.
  const float diff = q[node.dim] - node.split;
  const int32_t near = diff < 0.0f ? node.left : node.right;
  const int32_t far = diff < 0.0f ? node.right : node.left;
  Search(near, q, exclude, best);
  if (diff * diff <= best.distance_sq) {
    Search(far, q, exclude, best);
  }
}

PointKdTree::Neighbor PointKdTree::Nearest(const Eigen::Vector3f& query, int64_t exclude) const {
  Neighbor best;
  if (!nodes_.empty()) {
    Search(0, query, exclude, best);
  }
  return best;
}

}  // namespace dome::eval
