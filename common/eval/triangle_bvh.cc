#include "eval/triangle_bvh.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <numeric>

#include "core/error.h"

namespace dome::eval {
namespace {

constexpr int kLeafSize = 4;

Eigen::Vector3d ClosestPointOnSegment(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                      const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double len_sq = ab.squaredNorm();
  if (len_sq <= 0.0) {
    return a;
  }
  const double t = std::clamp((p - a).dot(ab) / len_sq, 0.0, 1.0);
  return a + t * ab;
}

}  // namespace

Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                       const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a;
  // Ericson's divisions are by |ab|^2, |ac|^2, |bc|^2 and |ab x ac|^2: a collinear or
  // collapsed triangle is its longest edge, so take the nearest of the three edges.
  const double scale = std::max({ab.squaredNorm(), ac.squaredNorm(), (c - b).squaredNorm()});
  if (ab.cross(ac).squaredNorm() <= 1e-20 * scale * scale) {
    const Eigen::Vector3d candidates[3] = {ClosestPointOnSegment(p, a, b),
                                           ClosestPointOnSegment(p, b, c),
                                           ClosestPointOnSegment(p, c, a)};
    int best = 0;
    for (int i = 1; i < 3; ++i) {
      if ((candidates[i] - p).squaredNorm() < (candidates[best] - p).squaredNorm()) {
        best = i;
      }
    }
    return candidates[best];
  }
  const Eigen::Vector3d ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) {
    return a;  // vertex region a
  }
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) {
    return b;  // vertex region b
  }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    return a + (d1 / (d1 - d3)) * ab;  // edge ab
  }
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) {
    return c;  // vertex region c
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    return a + (d2 / (d2 - d6)) * ac;  // edge ac
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {  // edge bc
    return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  }
  const double denom = 1.0 / (va + vb + vc);  // face region
  return a + ab * (vb * denom) + ac * (vc * denom);
}

double PointTriangleDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                             const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  return (ClosestPointOnTriangle(p, a, b, c) - p).norm();
}

TriangleBvh::TriangleBvh(const std::vector<Eigen::Vector3f>& vertices,
                         const std::vector<Eigen::Vector3i>& faces) {
  DOME_CHECK(faces.size() < static_cast<size_t>(std::numeric_limits<int32_t>::max()),
             "TriangleBvh: too many faces");
  std::vector<Triangle> input;
  input.reserve(faces.size());
  std::vector<Eigen::Vector3f> centroids;
  centroids.reserve(faces.size());
  for (size_t f = 0; f < faces.size(); ++f) {
    for (int k = 0; k < 3; ++k) {
      DOME_CHECK(faces[f][k] >= 0 && static_cast<size_t>(faces[f][k]) < vertices.size(),
                 "TriangleBvh: face index out of range");
    }
    const Triangle t{vertices[faces[f][0]], vertices[faces[f][1]], vertices[faces[f][2]],
                     static_cast<int32_t>(f)};
    input.push_back(t);
    centroids.push_back((t.a + t.b + t.c) / 3.0f);
  }
  if (input.empty()) {
    return;
  }
  // Build over a permutation; the triangles are gathered into leaf order once at the
  // end so a leaf's triangles are contiguous for the query loop.
  std::vector<int32_t> order(input.size());
  std::iota(order.begin(), order.end(), 0);
  nodes_.reserve(2 * input.size() / kLeafSize + 1);
  Build(0, static_cast<int32_t>(input.size()), input, centroids, order);
  triangles_.reserve(input.size());
  for (const int32_t i : order) {
    triangles_.push_back(input[i]);
  }
}

int32_t TriangleBvh::Build(int32_t begin, int32_t end, const std::vector<Triangle>& input,
                           const std::vector<Eigen::Vector3f>& centroids,
                           std::vector<int32_t>& order) {
  const int32_t id = static_cast<int32_t>(nodes_.size());
  nodes_.emplace_back();
  Eigen::Vector3f lo = input[order[begin]].a, hi = lo;
  Eigen::Vector3f clo = centroids[order[begin]], chi = clo;
  for (int32_t i = begin; i < end; ++i) {
    const Triangle& t = input[order[i]];
    lo = lo.cwiseMin(t.a).cwiseMin(t.b).cwiseMin(t.c);
    hi = hi.cwiseMax(t.a).cwiseMax(t.b).cwiseMax(t.c);
    clo = clo.cwiseMin(centroids[order[i]]);
    chi = chi.cwiseMax(centroids[order[i]]);
  }
  nodes_[id].lo = lo;
  nodes_[id].hi = hi;
  if (end - begin <= kLeafSize) {
    nodes_[id].begin = begin;
    nodes_[id].end = end;
    return id;
  }
  int dim = 0;
  (chi - clo).maxCoeff(&dim);
  const int32_t mid = begin + (end - begin) / 2;
  std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                   [&](int32_t a, int32_t b) { return centroids[a][dim] < centroids[b][dim]; });
  const int32_t left = Build(begin, mid, input, centroids, order);
  const int32_t right = Build(mid, end, input, centroids, order);
  nodes_[id].left = left;
  nodes_[id].right = right;
  return id;
}

double TriangleBvh::BoxDistanceSq(const Node& node, const Eigen::Vector3d& q) const {
  const Eigen::Vector3d lo = node.lo.cast<double>(), hi = node.hi.cast<double>();
  return ((lo - q).cwiseMax(0.0).cwiseMax(q - hi)).squaredNorm();
}

void TriangleBvh::Search(int32_t id, const Eigen::Vector3d& q, Hit& best) const {
  const Node& node = nodes_[id];
  if (node.left < 0) {
    for (int32_t i = node.begin; i < node.end; ++i) {
      const Triangle& t = triangles_[i];
      const Eigen::Vector3d p =
          ClosestPointOnTriangle(q, t.a.cast<double>(), t.b.cast<double>(), t.c.cast<double>());
      const double d2 = (p - q).squaredNorm();
      if (d2 < best.distance_sq) {
        best.distance_sq = d2;
        best.face = t.face;
        best.point = p;
      }
    }
    return;
  }
  const double dl = BoxDistanceSq(nodes_[node.left], q);
  const double dr = BoxDistanceSq(nodes_[node.right], q);
  const int32_t first = dl <= dr ? node.left : node.right;
  const int32_t second = dl <= dr ? node.right : node.left;
  const double d_first = std::min(dl, dr), d_second = std::max(dl, dr);
  if (d_first < best.distance_sq) {
    Search(first, q, best);
  }
  if (d_second < best.distance_sq) {
    Search(second, q, best);
  }
}

TriangleBvh::Hit TriangleBvh::Closest(const Eigen::Vector3d& query) const {
  Hit best;
  if (!nodes_.empty()) {
    Search(0, query, best);
  }
  return best;
}

}  // namespace dome::eval
