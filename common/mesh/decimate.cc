#include "mesh/decimate.h"

#include <meshoptimizer.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "core/disjoint_sets.h"
#include "core/error.h"
#include "core/parallel_for.h"
#include "core/timer.h"

namespace dome::mesh {
namespace {

// For every input vertex kept in `kept_indices`, the position minimizing the
// area-weighted squared distances to the planes of the input faces of its cluster
// (input vertices assigned to the nearest kept vertex in edge hops, ties to the first
// reached); directions the planes leave undetermined (singular values below 1e-3 of
// the largest) keep the current position. Open-border vertices and vertices of
// clusters without faces stay. Returns positions for all input vertices.
std::vector<Eigen::Vector3f> RelocatedPositions(const io::Mesh& mesh,
                                                const std::vector<unsigned int>& kept_indices) {
  const size_t nv = mesh.vertices.size();
  std::vector<Eigen::Vector3f> pos = mesh.vertices;
  // Vertex adjacency (CSR) and border vertices (an edge used by one face).
  std::vector<std::pair<int, int>> edges;
  edges.reserve(mesh.faces.size() * 3);
  for (const auto& f : mesh.faces) {
    for (int m = 0; m < 3; ++m) edges.emplace_back(f[m], f[(m + 1) % 3]);
  }
  std::vector<int> start(nv + 1, 0), adj(edges.size() * 2);
  for (const auto& e : edges) {
    ++start[e.first + 1];
    ++start[e.second + 1];
  }
  for (size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (const auto& e : edges) {
    adj[fill[e.first]++] = e.second;
    adj[fill[e.second]++] = e.first;
  }
  std::vector<uint8_t> border(nv, 0);
  for (size_t v = 0; v < nv; ++v) {
    // An edge (v, w) is a border edge when it appears once in either direction.
    std::vector<int> nb(adj.begin() + start[v], adj.begin() + start[v + 1]);
    std::sort(nb.begin(), nb.end());
    for (size_t a = 0; a < nb.size();) {
      size_t b = a;
      while (b < nb.size() && nb[b] == nb[a]) ++b;
      if (b - a == 1) border[v] = 1;
      a = b;
    }
  }
  // Multi-source breadth-first search from the kept vertices.
  std::vector<int> owner(nv, -1), queue;
  queue.reserve(nv);
  for (unsigned int v : kept_indices) {
    if (owner[v] < 0) {
      owner[v] = int(v);
      queue.push_back(int(v));
    }
  }
  for (size_t q = 0; q < queue.size(); ++q) {
    const int v = queue[q];
    for (int a = start[v]; a < start[v + 1]; ++a) {
      if (owner[adj[a]] < 0) {
        owner[adj[a]] = owner[v];
        queue.push_back(adj[a]);
      }
    }
  }
  // Quadrics sum area * n n^T and area * n (n . p) per kept vertex, in coordinates
  // relative to the kept vertex (well conditioned far from the origin).
  std::vector<Eigen::Matrix3d> a_sum(nv);
  std::vector<Eigen::Vector3d> b_sum(nv);
  std::vector<uint8_t> has(nv, 0);
  for (const auto& f : mesh.faces) {
    const Eigen::Vector3d p0 = mesh.vertices[f[0]].cast<double>();
    const Eigen::Vector3d cr =
        (mesh.vertices[f[1]].cast<double>() - p0).cross(mesh.vertices[f[2]].cast<double>() - p0);
    const double twice_area = cr.norm();
    if (!(twice_area > 0)) continue;
    const Eigen::Vector3d n = cr / twice_area;
    int done[3] = {-1, -1, -1};
    for (int m = 0; m < 3; ++m) {
      const int o = owner[f[m]];
      if (o < 0 || o == done[0] || o == done[1]) continue;
      done[m] = o;
      if (!has[o]) {
        a_sum[o].setZero();
        b_sum[o].setZero();
        has[o] = 1;
      }
      const double d = n.dot(p0 - mesh.vertices[o].cast<double>());
      a_sum[o] += 0.5 * twice_area * n * n.transpose();
      b_sum[o] += 0.5 * twice_area * d * n;
    }
  }
  for (unsigned int v : kept_indices) {
    if (!has[v] || border[v]) continue;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(a_sum[v]);
    const Eigen::Vector3d lambda = eig.eigenvalues();
    const double top = lambda.maxCoeff();
    if (!(top > 0)) continue;
    Eigen::Vector3d x = Eigen::Vector3d::Zero();  // offset from the current position
    for (int k = 0; k < 3; ++k) {
      if (lambda[k] > 1e-3 * top) {
        const Eigen::Vector3d e = eig.eigenvectors().col(k);
        x += e * (e.dot(b_sum[v]) / lambda[k]);
      }
    }
    pos[v] = (mesh.vertices[v].cast<double>() + x).cast<float>();
  }
  return pos;
}

// Nearest-point distances through a balanced kd-tree kept implicitly in the point order
// (node = middle of its range, split axis by depth). Queries are const: several threads
// may ask one tree.
class PointTree {
 public:
  explicit PointTree(std::vector<Eigen::Vector3d> points) : points_(std::move(points)) {
    Build(0, int(points_.size()), 0);
  }
  // Distance from q to the nearest point (HUGE_VAL when there is none).
  double Nearest(const Eigen::Vector3d& q) const {
    double best2 = HUGE_VAL;
    Search(q, 0, int(points_.size()), 0, &best2);
    return std::sqrt(best2);
  }

 private:
  void Build(int lo, int hi, int axis) {
    if (hi - lo <= 1) return;
    const int mid = (lo + hi) / 2;
    std::nth_element(points_.begin() + lo, points_.begin() + mid, points_.begin() + hi,
                     [axis](const auto& a, const auto& b) { return a[axis] < b[axis]; });
    Build(lo, mid, (axis + 1) % 3);
    Build(mid + 1, hi, (axis + 1) % 3);
  }
  void Search(const Eigen::Vector3d& q, int lo, int hi, int axis, double* best2) const {
    if (lo >= hi) return;
    const int mid = (lo + hi) / 2;
    *best2 = std::min(*best2, (points_[mid] - q).squaredNorm());
    const double diff = q[axis] - points_[mid][axis];
    const int next = (axis + 1) % 3;
    if (diff < 0) {
      Search(q, lo, mid, next, best2);
      if (diff * diff < *best2) Search(q, mid + 1, hi, next, best2);
    } else {
      Search(q, mid + 1, hi, next, best2);
      if (diff * diff < *best2) Search(q, lo, mid, next, best2);
    }
  }
  std::vector<Eigen::Vector3d> points_;
};

// For each query, whether some point is within `radius` of it: the points bucketed in
// cubic cells of that edge (sorted by cell), each query checking the 27 cells around its
// own, found through a hash table of the cells' runs. (A kd-tree's nearest distance took
// 0.2 s for the queries of a paper instant; a binary search of the sorted points per
// cell, 27 a query, 0.06 CPU s more than the table on a Robovision surface's 78 k.)
std::vector<uint8_t> WithinDistance(const std::vector<Eigen::Vector3d>& points,
                                    const std::vector<Eigen::Vector3d>& queries, double radius,
                                    int num_threads) {
  std::vector<uint8_t> out(queries.size(), 0);
  if (points.empty() || !(radius > 0)) return out;
  const auto cell = [radius](const Eigen::Vector3d& p) {
    return Eigen::Vector3i(int(std::floor(p.x() / radius)), int(std::floor(p.y() / radius)),
                           int(std::floor(p.z() / radius)));
  };
  // 21 bits a coordinate: cells of any radius over any scene dome meshes come from. The
  // top bit stays clear, so kNoCell is no cell's key.
  const auto key = [](const Eigen::Vector3i& c) {
    return (uint64_t(uint32_t(c.x()) & 0x1fffff) << 42) |
           (uint64_t(uint32_t(c.y()) & 0x1fffff) << 21) | uint64_t(uint32_t(c.z()) & 0x1fffff);
  };
  constexpr uint64_t kNoCell = ~uint64_t{0};
  std::vector<std::pair<uint64_t, int>> sorted(points.size());
  for (size_t i = 0; i < points.size(); ++i) sorted[i] = {key(cell(points[i])), int(i)};
  std::sort(sorted.begin(), sorted.end());
  // Open addressing, at most half full: each cell's key and its run [begin, end) of
  // `sorted`.
  struct Run {
    uint64_t key;
    uint32_t begin, end;
  };
  size_t runs = 0;
  for (size_t i = 0; i < sorted.size(); ++i)
    runs += i == 0 || sorted[i].first != sorted[i - 1].first;
  int bits = 1;
  while ((size_t{1} << bits) < 2 * runs) ++bits;
  const uint64_t mask = (uint64_t{1} << bits) - 1;
  const auto slot_of = [bits](uint64_t k) { return (k * 0x9e3779b97f4a7c15ull) >> (64 - bits); };
  std::vector<Run> table(size_t{1} << bits, Run{kNoCell, 0, 0});
  for (size_t i = 0; i < sorted.size();) {
    size_t j = i;
    while (j < sorted.size() && sorted[j].first == sorted[i].first) ++j;
    uint64_t at = slot_of(sorted[i].first);
    while (table[at].key != kNoCell) at = (at + 1) & mask;
    table[at] = {sorted[i].first, uint32_t(i), uint32_t(j)};
    i = j;
  }
  const double r2 = radius * radius;
  // Each query on its own: split over the threads (a Robovision surface's specks ask
  // 78 k of them).
  core::ParallelFor(0, int64_t(queries.size()), num_threads, [&](int64_t qb, int64_t qe) {
    for (size_t q = size_t(qb); q < size_t(qe); ++q) {
      const Eigen::Vector3i c = cell(queries[q]);
      for (int dz = -1; dz <= 1 && !out[q]; ++dz) {
        for (int dy = -1; dy <= 1 && !out[q]; ++dy) {
          for (int dx = -1; dx <= 1 && !out[q]; ++dx) {
            const uint64_t k = key(c + Eigen::Vector3i(dx, dy, dz));
            uint64_t at = slot_of(k);
            while (table[at].key != kNoCell && table[at].key != k) at = (at + 1) & mask;
            if (table[at].key != k) continue;
            for (uint32_t i = table[at].begin; i < table[at].end; ++i) {
              if ((points[size_t(sorted[i].second)] - queries[q]).squaredNorm() <= r2) {
                out[q] = 1;
                break;
              }
            }
          }
        }
      }
    }
  });
  return out;
}

// What the component filters drop: parts too small in triangles or diagonal, and specks.
struct ComponentFilter {
  int64_t min_triangles = 0;
  double min_diagonal_mm = 0.0;
  double speck_area_fraction = 0.0, speck_diagonal_mm = 0.0, speck_gap_mm = 0.0;
  int64_t removed = 0, specks = 0, speck_triangles = 0;  // what was dropped
};

// The faces of `mesh` whose connected component (faces joined by shared vertices) passes
// `filter` (DecimationOptions: min_component_*, speck_*); counts what it drops.
std::vector<Eigen::Vector3i> KeptComponentFaces(const io::Mesh& mesh, ComponentFilter* filter,
                                                int num_threads) {
  const int nv = int(mesh.vertices.size());
  core::DisjointSets sets(mesh.vertices.size());
  for (const auto& f : mesh.faces) {
    for (int m = 1; m < 3; ++m) sets.Union(f[0], f[m]);
  }
  // Each vertex's component once: the loops below look it up per face and vertex.
  std::vector<int> root(static_cast<size_t>(nv));
  for (int v = 0; v < nv; ++v) root[size_t(v)] = sets.Find(v);
  auto find = [&](int v) { return root[size_t(v)]; };
  std::vector<int64_t> count(nv, 0);
  std::vector<double> area(nv, 0.0);
  std::vector<Eigen::Vector3f> lo(nv, Eigen::Vector3f::Constant(HUGE_VALF)),
      hi(nv, Eigen::Vector3f::Constant(-HUGE_VALF));
  for (const auto& f : mesh.faces) {
    const int r = find(f[0]);
    ++count[r];
    const Eigen::Vector3d a = mesh.vertices[f[0]].cast<double>();
    area[r] += 0.5 * (mesh.vertices[f[1]].cast<double>() - a)
                         .cross(mesh.vertices[f[2]].cast<double>() - a)
                         .norm();
    for (int m = 0; m < 3; ++m) {
      lo[r] = lo[r].cwiseMin(mesh.vertices[f[m]]);
      hi[r] = hi[r].cwiseMax(mesh.vertices[f[m]]);
    }
  }
  const double largest = nv > 0 ? *std::max_element(area.begin(), area.end()) : 0.0;
  const bool specks = filter->speck_area_fraction > 0 && filter->speck_diagonal_mm > 0;
  std::vector<uint8_t> drop(nv, 0), small(nv, 0);
  bool any_small = false;
  for (int r = 0; r < nv; ++r) {
    if (count[r] == 0) continue;
    const double diagonal = double((hi[r] - lo[r]).norm());
    if (count[r] < filter->min_triangles || diagonal < filter->min_diagonal_mm) {
      drop[r] = 1;
      ++filter->removed;
    } else if (specks && area[r] < filter->speck_area_fraction * largest &&
               diagonal < filter->speck_diagonal_mm) {
      small[r] = 1;
      any_small = true;
    }
  }
  if (any_small) {
    // Each small part's nearest vertex to the vertices of the parts that are not small.
    std::vector<double> gap(nv, HUGE_VAL);
    if (filter->speck_gap_mm > 0) {
      std::vector<uint8_t> used(nv, 0);
      std::vector<Eigen::Vector3d> large_points, queries;
      std::vector<int> query_root;
      for (const auto& f : mesh.faces) {
        for (int m = 0; m < 3; ++m) {
          if (used[f[m]]) continue;
          used[f[m]] = 1;
          const int r = find(f[m]);
          if (drop[r]) continue;
          if (small[r]) {
            queries.push_back(mesh.vertices[f[m]].cast<double>());
            query_root.push_back(r);
          } else {
            large_points.push_back(mesh.vertices[f[m]].cast<double>());
          }
        }
      }
      const std::vector<uint8_t> near =
          WithinDistance(large_points, queries, filter->speck_gap_mm, num_threads);
      for (size_t i = 0; i < near.size(); ++i) {
        if (near[i]) gap[query_root[i]] = 0.0;
      }
    }
    for (int r = 0; r < nv; ++r) {
      if (!small[r] || gap[r] <= filter->speck_gap_mm) continue;
      drop[r] = 1;
      ++filter->specks;
      filter->speck_triangles += count[r];
    }
  }
  std::vector<Eigen::Vector3i> kept;
  kept.reserve(mesh.faces.size());
  for (const auto& f : mesh.faces) {
    if (!drop[find(f[0])]) kept.push_back(f);
  }
  return kept;
}

// Squared distance from p to the triangle abc (closest point by the Voronoi regions of
// the corners, edges and face).
double PointTriangleDistance2(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                              const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return ap.squaredNorm();
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return bp.squaredNorm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return (ap - ab * (d1 / (d1 - d3))).squaredNorm();
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return cp.squaredNorm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return (ap - ac * (d2 / (d2 - d6))).squaredNorm();
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
    return (bp - (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))).squaredNorm();
  }
  const double sum = va + vb + vc;
  if (!(sum > 0)) {  // degenerate: the nearest of its edges
    auto seg = [&](const Eigen::Vector3d& s, const Eigen::Vector3d& t) {
      const Eigen::Vector3d e = t - s;
      const double l2 = e.squaredNorm();
      const double h = l2 > 0 ? std::clamp((p - s).dot(e) / l2, 0.0, 1.0) : 0.0;
      return (p - s - h * e).squaredNorm();
    };
    return std::min({seg(a, b), seg(b, c), seg(c, a)});
  }
  return (ap - ab * (vb / sum) - ac * (vc / sum)).squaredNorm();
}

// A min-heap of (cost, id) pairs, ids in [0, size), each id's slot tracked so that an
// entry's cost can be changed or the entry removed where it is: the collapser keeps one
// entry per edge and never a stale one (a queue of stale copies made 12 pushes and pops
// a collapse, each a run of cache misses through a heap of ~600 k entries). Ties go to
// the smaller id, so the order is the same on every run. 4 children per node: each
// move also writes the moved id's slot, so shallower is not cheaper here.
class IndexedHeap {
 public:
  void Reset(size_t ids) {
    slot_.assign(ids, -1);
    items_.clear();
  }
  bool empty() const { return items_.empty(); }
  bool Contains(int id) const { return slot_[size_t(id)] >= 0; }
  int Top() const { return items_[0].id; }
  // Adds without ordering: call Heapify before any other change.
  void Append(int id, float cost) {
    slot_[size_t(id)] = int(items_.size());
    items_.push_back({cost, id});
  }
  void Heapify() {
    for (size_t i = items_.size() / kArity + 1; i-- > 0;) {
      if (i < items_.size()) SiftDown(i);
    }
  }
  // Inserts id or changes its cost.
  void Set(int id, float cost) {
    const int at = slot_[size_t(id)];
    if (at < 0) {
      items_.push_back({cost, id});
      SiftUp(items_.size() - 1);
      return;
    }
    const float old = items_[size_t(at)].cost;
    items_[size_t(at)].cost = cost;
    if (cost < old) {
      SiftUp(size_t(at));
    } else {
      SiftDown(size_t(at));
    }
  }
  void Remove(int id) {
    const int at = slot_[size_t(id)];
    if (at < 0) return;
    slot_[size_t(id)] = -1;
    const Item last = items_.back();
    items_.pop_back();
    if (size_t(at) == items_.size()) return;
    items_[size_t(at)] = last;
    slot_[size_t(last.id)] = at;
    SiftUp(size_t(at));
    SiftDown(size_t(slot_[size_t(last.id)]));
  }

 private:
  struct Item {
    float cost;
    int id;
  };
  static constexpr size_t kArity = 4;
  static bool Less(const Item& a, const Item& b) {
    return a.cost < b.cost || (a.cost == b.cost && a.id < b.id);
  }
  void Place(size_t i, const Item& item) {
    items_[i] = item;
    slot_[size_t(item.id)] = int(i);
  }
  void SiftUp(size_t i) {
    const Item item = items_[i];
    while (i > 0) {
      const size_t parent = (i - 1) / kArity;
      if (!Less(item, items_[parent])) break;
      Place(i, items_[parent]);
      i = parent;
    }
    Place(i, item);
  }
  void SiftDown(size_t i) {
    const size_t n = items_.size();
    const Item item = items_[i];
    for (;;) {
      const size_t first = i * kArity + 1;
      if (first >= n) break;
      const size_t last = std::min(first + kArity, n);
      size_t best = first;
      for (size_t c = first + 1; c < last; ++c) {
        if (Less(items_[c], items_[best])) best = c;
      }
      if (!Less(items_[best], item)) break;
      Place(i, items_[best]);
      i = best;
    }
    Place(i, item);
  }
  std::vector<Item> items_;
  std::vector<int> slot_;  // per id, its index in items_, or -1
};

// Symmetric quadric x^T A x + 2 b.x + c: area-weighted squared distances to planes.
struct Quadric {
  double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0, b0 = 0, b1 = 0, b2 = 0, c = 0;

  // The plane n.x + d = 0 (n unit) with weight w.
  void AddPlane(const Eigen::Vector3d& n, double d, double w) {
    a00 += w * n.x() * n.x();
    a01 += w * n.x() * n.y();
    a02 += w * n.x() * n.z();
    a11 += w * n.y() * n.y();
    a12 += w * n.y() * n.z();
    a22 += w * n.z() * n.z();
    b0 += w * d * n.x();
    b1 += w * d * n.y();
    b2 += w * d * n.z();
    c += w * d * d;
  }
  Quadric& operator+=(const Quadric& o) {
    a00 += o.a00, a01 += o.a01, a02 += o.a02, a11 += o.a11, a12 += o.a12, a22 += o.a22;
    b0 += o.b0, b1 += o.b1, b2 += o.b2, c += o.c;
    return *this;
  }
  Eigen::Matrix3d A() const {
    Eigen::Matrix3d m;
    m << a00, a01, a02, a01, a11, a12, a02, a12, a22;
    return m;
  }
  Eigen::Vector3d B() const { return Eigen::Vector3d(b0, b1, b2); }
  double Eval(const Eigen::Vector3d& x) const { return x.dot(A() * x) + 2.0 * B().dot(x) + c; }
  double Weight() const { return a00 + a11 + a22; }  // sum of the plane weights
};

// The frame of the collapser's positions and quadrics: the vertex centroid (well
// conditioned far from the world origin).
Eigen::Vector3d QuadricOrigin(const io::Mesh& mesh) {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  for (const auto& p : mesh.vertices) origin += p.cast<double>();
  if (!mesh.vertices.empty()) origin /= double(mesh.vertices.size());
  return origin;
}

// Per vertex, the planes of `faces` around it, each weighted by its area (Garland &
// Heckbert); `pos` in the frame the quadrics are to be in.
std::vector<Quadric> PlaneQuadrics(const std::vector<Eigen::Vector3d>& pos,
                                   const std::vector<Eigen::Vector3i>& faces) {
  std::vector<Quadric> quad(pos.size());
  for (const auto& f : faces) {
    const Eigen::Vector3d& p0 = pos[size_t(f[0])];
    const Eigen::Vector3d cr = (pos[size_t(f[1])] - p0).cross(pos[size_t(f[2])] - p0);
    const double len = cr.norm();
    if (!(len > 0)) continue;
    const Eigen::Vector3d n = cr / len;
    for (int m = 0; m < 3; ++m) quad[size_t(f[m])].AddPlane(n, -n.dot(p0), 0.5 * len);
  }
  return quad;
}

// The vertices of `mesh` in QuadricOrigin's frame.
std::vector<Eigen::Vector3d> RelativePositions(const io::Mesh& mesh,
                                               const Eigen::Vector3d& origin) {
  std::vector<Eigen::Vector3d> pos(mesh.vertices.size());
  for (size_t v = 0; v < pos.size(); ++v) pos[v] = mesh.vertices[v].cast<double>() - origin;
  return pos;
}

// The penalty plane holding the open-border edge u-w of face t in place, added to the
// quadrics `to` (both endpoints'): it contains the edge and is perpendicular to the face,
// weighted `weight` times the edge length squared (DecimationOptions::border_weight).
void AddBorderPlane(const std::vector<Eigen::Vector3d>& pos, const Eigen::Vector3i& t, int u, int w,
                    double weight, std::initializer_list<Quadric*> to) {
  const Eigen::Vector3d n = (pos[size_t(t[1])] - pos[size_t(t[0])])
                                .cross(pos[size_t(t[2])] - pos[size_t(t[0])])
                                .normalized();
  const Eigen::Vector3d e = pos[size_t(w)] - pos[size_t(u)];
  const Eigen::Vector3d p = e.cross(n);
  if (p.squaredNorm() > 0 && n.allFinite()) {
    const Eigen::Vector3d pn = p.normalized();
    for (Quadric* q : to) {
      if (q) q->AddPlane(pn, -pn.dot(pos[size_t(u)]), weight * e.squaredNorm());
    }
  }
}

// The quadrics of `faces` (PlaneQuadrics) summed per kept vertex over its cluster: the
// input vertices nearest to it in edge hops (multi-source breadth-first search from the
// kept vertices, ties to the first reached), as if the collapses that made the kept
// mesh had merged them into it. Vertices no kept vertex reaches add nothing.
std::vector<Quadric> ClusterQuadrics(const io::Mesh& mesh,
                                     const std::vector<Eigen::Vector3i>& faces,
                                     const std::vector<unsigned int>& kept_indices) {
  const size_t nv = mesh.vertices.size();
  std::vector<int> start(nv + 1, 0);
  for (const auto& f : faces) {
    for (int m = 0; m < 3; ++m) start[f[m] + 1] += 2;
  }
  for (size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  std::vector<int> adj(static_cast<size_t>(start[nv]));
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (const auto& f : faces) {
    for (int m = 0; m < 3; ++m) {
      adj[size_t(fill[f[m]]++)] = f[(m + 1) % 3];
      adj[size_t(fill[f[m]]++)] = f[(m + 2) % 3];
    }
  }
  std::vector<int> owner(nv, -1), queue;
  queue.reserve(nv);
  for (unsigned int v : kept_indices) {
    if (owner[v] < 0) owner[v] = int(v), queue.push_back(int(v));
  }
  for (size_t q = 0; q < queue.size(); ++q) {
    const int v = queue[q];
    for (int a = start[v]; a < start[v + 1]; ++a) {
      if (owner[adj[a]] < 0) owner[adj[a]] = owner[v], queue.push_back(adj[a]);
    }
  }
  const std::vector<Quadric> input =
      PlaneQuadrics(RelativePositions(mesh, QuadricOrigin(mesh)), faces);
  std::vector<Quadric> out(nv);
  for (size_t v = 0; v < nv; ++v) {
    if (owner[v] >= 0) out[size_t(owner[v])] += input[v];
  }
  return out;
}

// Per vertex, the faces around it (face indices in the order they were added), each
// vertex's list inline in one 64-byte record while it holds up to 14 faces (nearly all
// do) and in a vector of its own beyond: the collapse loop reads a vertex's faces with
// one cache miss instead of two (the vector's header, then its buffer). Lists behave as
// std::vector<int>: appends at the end, removals keep the order.
class FaceLists {
 public:
  struct Range {
    int* first;
    int* last;
    int* begin() const { return first; }
    int* end() const { return last; }
    size_t size() const { return size_t(last - first); }
    bool empty() const { return first == last; }
  };
  void Resize(size_t n) { slots_.assign(n, Slot{}); }
  size_t size() const { return slots_.size(); }
  Range operator[](size_t v) {
    Slot& s = slots_[v];
    if (s.spill < 0) return {s.items, s.items + s.size};
    std::vector<int>& list = spilled_[size_t(s.spill)];
    return {list.data(), list.data() + list.size()};
  }
  void Add(int v, int f) {
    Slot& s = slots_[size_t(v)];
    if (s.spill < 0 && s.size < kInline) {
      s.items[s.size++] = f;
      return;
    }
    if (s.spill < 0) {
      s.spill = int(spilled_.size());
      spilled_.emplace_back(s.items, s.items + s.size);
    }
    spilled_[size_t(s.spill)].push_back(f);
  }
  // Removes the first occurrence of f (which must be there).
  void Remove(int v, int f) {
    Slot& s = slots_[size_t(v)];
    if (s.spill >= 0) {
      std::vector<int>& list = spilled_[size_t(s.spill)];
      list.erase(std::find(list.begin(), list.end(), f));
      return;
    }
    int* end = s.items + s.size;
    int* at = std::find(s.items, end, f);
    std::copy(at + 1, end, at);
    --s.size;
  }
  template <typename Pred>
  void RemoveIf(int v, Pred pred) {
    Slot& s = slots_[size_t(v)];
    if (s.spill >= 0) {
      std::vector<int>& list = spilled_[size_t(s.spill)];
      list.erase(std::remove_if(list.begin(), list.end(), pred), list.end());
      return;
    }
    s.size = int(std::remove_if(s.items, s.items + s.size, pred) - s.items);
  }
  void Clear(int v) {
    Slot& s = slots_[size_t(v)];
    if (s.spill >= 0) std::vector<int>().swap(spilled_[size_t(s.spill)]);
    s.spill = -1;
    s.size = 0;
  }

 private:
  static constexpr int kInline = 14;
  struct alignas(64) Slot {
    int size = 0;
    int spill = -1;  // index in spilled_, or -1: the list is in items
    int items[kInline];
  };
  std::vector<Slot> slots_;
  std::vector<std::vector<int>> spilled_;
};

// What an EdgeCollapser starts from: a mesh in a frame near its vertices (positions
// relative to `origin`, well conditioned far from the world origin), with the state a
// region's collapses hand on to the pass over the joined regions.
struct CollapseInput {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // world position of the frame, mm
  std::vector<Eigen::Vector3d> pos;                  // per vertex, from origin, mm
  std::vector<Eigen::Vector3f> colors;               // per vertex, 0-255, or none
  std::vector<Eigen::Vector3f> normals;              // per vertex, or none
  std::vector<float> alphas;                         // per vertex, 0-255, or none
  std::vector<Eigen::Vector3i> faces;
  // Per vertex, in the frame above; none: the planes of `faces` (PlaneQuadrics).
  std::vector<Quadric> quadrics;
  // Whether to add the border penalty planes (false: `quadrics` carry them already).
  bool border_planes = true;
  // Per vertex, or none: shared with another region (Seam). Such a vertex stays where
  // it is, no component that holds one is deleted, and no collapse joins two of them by
  // a new edge (the other region cannot see it).
  std::vector<uint8_t> seam;
  // The vertices of the input's largest component (frame above), for the distances of
  // the component deletions; null: this mesh's largest component.
  const PointTree* largest = nullptr;
};

CollapseInput InputFromMesh(const io::Mesh& mesh, const std::vector<Eigen::Vector3i>& faces) {
  CollapseInput in;
  in.origin = QuadricOrigin(mesh);
  in.pos = RelativePositions(mesh, in.origin);
  if (mesh.HasColors()) {
    in.colors.resize(mesh.vertices.size());
    for (size_t v = 0; v < in.colors.size(); ++v) in.colors[v] = mesh.colors[v].cast<float>();
  }
  if (mesh.HasNormals()) in.normals = mesh.normals;
  if (mesh.HasAlphas()) in.alphas.assign(mesh.alphas.begin(), mesh.alphas.end());
  in.faces = faces;
  return in;
}

// Greedy quadric edge collapse on a face list.
class EdgeCollapser {
 public:
  EdgeCollapser(CollapseInput in, const DecimationOptions& o)
      : options_(o),
        origin_(in.origin),
        pos_(std::move(in.pos)),
        colors_(std::move(in.colors)),
        normals_(std::move(in.normals)),
        alphas_(std::move(in.alphas)),
        seam_(std::move(in.seam)),
        border_planes_(in.border_planes),
        largest_tree_(in.largest) {
    const size_t nv = pos_.size();
    alive_.assign(nv, 1);
    locked_.assign(nv, 0);
    border_.assign(nv, 0);
    vfaces_.Resize(nv);
    marks_.assign(nv, Marks{});
    if (!seam_.empty()) absorbed_.resize(nv);
    faces_.reserve(in.faces.size());
    for (const auto& f : in.faces) {
      if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) continue;
      const int id = int(faces_.size());
      faces_.push_back(f);
      for (int m = 0; m < 3; ++m) vfaces_.Add(f[m], id);
    }
    face_alive_.assign(faces_.size(), 1);
    live_ = int64_t(faces_.size());
    quad_ = in.quadrics.empty() ? PlaneQuadrics(pos_, faces_) : std::move(in.quadrics);
    ClassifyVertices();
    LabelComponents();
    LabelEdges();
  }

  int64_t live_faces() const { return live_; }
  double max_error_mm() const { return max_error_; }
  int64_t components_deleted() const { return components_deleted_; }
  int64_t triangles_deleted() const { return triangles_deleted_; }

  // Collapses (and deletes components) until `target` faces are left, cheapest first.
  // Every edge has one queue entry, its cost recomputed in place when an endpoint
  // changes. An edge refused for its shape or the error bound leaves the queue until an
  // endpoint changes; when the queue runs dry before the target, the refused edges are
  // queued again (their neighbourhoods may have changed), while that still helps.
  void Run(int64_t target) {
    const int n_edges = int(edge_.size());
    heap_.Reset(edge_.size() + comp_live_.size());
    for (int e = 0; e < n_edges; ++e) {
      if (edge_state_[e] == kEdgeQueued) heap_.Append(e, EdgeCost(e));
    }
    QueueComponentDeletions(/*heaped=*/false);
    heap_.Heapify();
    for (int pass = 0; pass < kMaxPasses && live_ > target; ++pass) {
      if (pass > 0) {
        // Dry before the target: the refused edges again, and the components left.
        for (int e = 0; e < n_edges; ++e) {
          if (edge_state_[e] == kEdgeRefused && alive_[edge_[e].a] && alive_[edge_[e].b]) {
            edge_state_[e] = kEdgeQueued;
            heap_.Set(e, EdgeCost(e));
          }
        }
        QueueComponentDeletions(/*heaped=*/true);
      }
      int64_t changes = 0;
      while (live_ > target && !heap_.empty()) {
        const int id = heap_.Top();
        if (id >= n_edges) {
          heap_.Remove(id);
          changes += DeleteComponent(id - n_edges, target);
          continue;
        }
        int keep = edge_[id].a, gone = edge_[id].b;
        if (!alive_[keep] || !alive_[gone]) {  // its component was deleted
          heap_.Remove(id);
          edge_state_[id] = kEdgeDead;
          continue;
        }
        if (locked_[gone]) std::swap(keep, gone);
        // The shape tests before the deviation: about half the edges that get here
        // fail them, at a fraction of the deviation's cost. The link condition first,
        // before the placement it does not need: on a Robovision surface 392 k of the
        // 1.04 M edges tested fail it, 33 k the flip test.
        const bool linked = LinkHolds(keep, gone);
        Eigen::Vector3d x = pos_[keep];
        double error = 0.0, w = 0.0;
        Quadric q;
        if (linked) {
          q = quad_[keep];
          q += quad_[gone];
          x = Placement(q, keep, gone);
          w = q.Weight();
          error = w > 0 ? std::sqrt(std::max(0.0, q.Eval(x)) / w) : 0.0;
        }
        if (!linked || (options_.max_error_mm > 0 && error > options_.max_error_mm) ||
            !NothingFlips(keep, gone, x)) {
          heap_.Remove(id);
          edge_state_[id] = kEdgeRefused;
          continue;
        }
        if (options_.deviation_weight > 0 && !deviation_costed_[id] &&
            (options_.deviation_from_factor == 0 ||
             double(live_) <= options_.deviation_from_factor * double(target))) {
          // Costed lazily, when the edge comes to the top (measuring the deviation takes
          // far longer than the quadric): the term only raises the cost, so the edge
          // moves down the queue when something else is now cheaper, and is made when it
          // comes to the top again unchanged.
          deviation_costed_[id] = 1;
          const double d = Deviation(keep, gone, x);
          // Rounding-level deviations (a flat region) leave the order as it was.
          const double negligible = kDeviationFloor * (pos_[keep] - pos_[gone]).norm();
          if (d > negligible) {
            // q.Eval(x) is the quadric cost the edge was queued at (same placement).
            heap_.Set(id, float(std::max(0.0, q.Eval(x)) + options_.deviation_weight * w * d * d));
            if (heap_.Top() != id) continue;
          }
        }
        heap_.Remove(id);
        Collapse(keep, gone, x);
        ++changes;
        max_error_ = std::max(max_error_, error);
      }
      if (changes == 0) break;
    }
  }

  // The live faces, their vertices renumbered in first-use order (*used: their ids
  // here).
  std::vector<Eigen::Vector3i> LiveFaces(std::vector<int>* used) const {
    std::vector<int> remap(pos_.size(), -1);
    std::vector<Eigen::Vector3i> out;
    used->clear();
    for (size_t f = 0; f < faces_.size(); ++f) {
      if (!face_alive_[f]) continue;
      Eigen::Vector3i face;
      for (int m = 0; m < 3; ++m) {
        const int v = faces_[f][m];
        if (remap[v] < 0) {
          remap[v] = int(used->size());
          used->push_back(v);
        }
        face[m] = remap[v];
      }
      out.push_back(face);
    }
    return out;
  }

  // The live mesh, for the pass over the joined regions: LiveFaces, and per vertex its
  // position, attributes and quadric (a seam vertex's: only those of the vertices
  // collapsed into it).
  void Export(std::vector<int>* used, CollapseInput* out) const {
    out->faces = LiveFaces(used);
    out->origin = origin_;
    out->pos.resize(used->size());
    out->quadrics.resize(used->size());
    out->colors.resize(colors_.empty() ? 0 : used->size());
    out->normals.resize(normals_.empty() ? 0 : used->size());
    out->alphas.resize(alphas_.empty() ? 0 : used->size());
    for (size_t i = 0; i < used->size(); ++i) {
      const size_t v = size_t((*used)[i]);
      out->pos[i] = pos_[v];
      out->quadrics[i] = Seam(int(v)) ? absorbed_[v] : quad_[v];
      if (!colors_.empty()) out->colors[i] = colors_[v];
      if (!normals_.empty()) out->normals[i] = normals_[v];
      if (!alphas_.empty()) out->alphas[i] = alphas_[v];
    }
  }

  io::Mesh Result() const {
    io::Mesh out;
    std::vector<int> used;
    out.faces = LiveFaces(&used);
    for (int v : used) {
      out.vertices.push_back((pos_[v] + origin_).cast<float>());
      if (!colors_.empty()) {
        out.colors.push_back(
            colors_[v].array().round().max(0.0f).min(255.0f).cast<uint8_t>().matrix());
      }
      if (!normals_.empty()) {
        const float len = normals_[v].norm();
        out.normals.push_back(len > 0 ? Eigen::Vector3f(normals_[v] / len) : normals_[v]);
      }
      if (!alphas_.empty()) {
        out.alphas.push_back(uint8_t(std::clamp(std::lround(alphas_[v]), 0l, 255l)));
      }
    }
    return out;
  }

 private:
  // An edge's state: in the queue, out of it until an endpoint changes (refused, or both
  // endpoints locked), or gone.
  static constexpr uint8_t kEdgeQueued = 0, kEdgeRefused = 1, kEdgeDead = 2;
  struct Edge {
    int a, b;
  };

  // One record per edge of faces_ (an edge id per face corner, for the edge from corner m
  // to m + 1), numbered by their smaller endpoint, then first use. Edges between two
  // locked vertices never collapse and start dead.
  void LabelEdges() {
    face_edges_.assign(faces_.size(), {-1, -1, -1});
    for (size_t u = 0; u < vfaces_.size(); ++u) {
      const uint32_t epoch = ++epoch_;
      for (int f : vfaces_[u]) {
        const auto& t = faces_[f];
        for (int m = 0; m < 3; ++m) {
          const int s = t[m], r = t[(m + 1) % 3];
          if (std::min(s, r) != int(u)) continue;
          const int w = s + r - int(u);
          if (marks_[w].u_epoch != epoch) {
            marks_[w].u_epoch = epoch;
            marks_[w].count_u = int(edge_.size());
            edge_.push_back({int(u), w});
          }
          face_edges_[size_t(f)][size_t(m)] = marks_[w].count_u;
        }
      }
    }
    edge_state_.assign(edge_.size(), kEdgeQueued);
    for (size_t e = 0; e < edge_.size(); ++e) {
      if (locked_[edge_[e].a] && locked_[edge_[e].b]) edge_state_[e] = kEdgeDead;
    }
    deviation_costed_.assign(edge_.size(), 0);
    edge_epoch_.assign(edge_.size(), 0);
  }

  // The quadric cost of collapsing edge e at its placement (the locked endpoint kept),
  // without the deviation term: the edge is queued at this cost whenever an endpoint
  // changes, the term added when it comes to the top (Run).
  double EdgeQuadricCost(int e) const {
    int keep = edge_[e].a, gone = edge_[e].b;
    if (locked_[gone]) std::swap(keep, gone);
    Quadric q = quad_[keep];
    q += quad_[gone];
    return std::max(0.0, q.Eval(Placement(q, keep, gone)));
  }
  float EdgeCost(int e) {
    deviation_costed_[e] = 0;
    return float(EdgeQuadricCost(e));
  }

  // Connected components (faces joined by shared vertices; collapses never join or split
  // them): their vertices, live triangles, area and bounding-box diagonal.
  void LabelComponents() {
    const int nv = int(pos_.size());
    core::DisjointSets sets(pos_.size());
    auto find = [&](int v) { return sets.Find(v); };
    for (const auto& f : faces_) {
      for (int m = 1; m < 3; ++m) sets.Union(f[0], f[m]);
    }
    std::vector<int> label(nv, -1);
    comp_of_.assign(nv, -1);
    int n = 0;
    for (int v = 0; v < nv; ++v) {
      if (vfaces_[v].empty()) continue;
      const int r = find(v);
      if (label[r] < 0) label[r] = n++;
      comp_of_[v] = label[r];
    }
    comp_live_.assign(n, 0);
    comp_area_.assign(n, 0.0);
    std::vector<Eigen::Vector3d> centroid(n, Eigen::Vector3d::Zero()),
        lo(n, Eigen::Vector3d::Constant(HUGE_VAL)), hi(n, Eigen::Vector3d::Constant(-HUGE_VAL));
    for (const auto& f : faces_) {
      const int c = comp_of_[f[0]];
      ++comp_live_[c];
      for (int m = 0; m < 3; ++m) {
        lo[c] = lo[c].cwiseMin(pos_[f[m]]);
        hi[c] = hi[c].cwiseMax(pos_[f[m]]);
      }
      const double area = 0.5 * (pos_[f[1]] - pos_[f[0]]).cross(pos_[f[2]] - pos_[f[0]]).norm();
      comp_area_[c] += area;
      centroid[c] += area / 3.0 * (pos_[f[0]] + pos_[f[1]] + pos_[f[2]]);
    }
    comp_diag_.resize(n);
    for (int c = 0; c < n; ++c) {
      if (comp_area_[c] > 0) centroid[c] /= comp_area_[c];
      comp_diag_[c] = (hi[c] - lo[c]).norm();
    }
    comp_start_.assign(n + 1, 0);
    for (int v = 0; v < nv; ++v) {
      if (comp_of_[v] >= 0) ++comp_start_[comp_of_[v] + 1];
    }
    for (int c = 0; c < n; ++c) comp_start_[c + 1] += comp_start_[c];
    comp_vertices_.resize(comp_start_[n]);
    std::vector<int> fill(comp_start_.begin(), comp_start_.end() - 1);
    for (int v = 0; v < nv; ++v) {
      if (comp_of_[v] >= 0) comp_vertices_[fill[comp_of_[v]]++] = v;
    }
    // Never deleted: the largest component, and in a region every part of a component
    // that goes on in another region (it holds a seam vertex). A region's other
    // components are whole components of the input, so the input's largest one, when it
    // lies in one region, is that region's largest.
    const int largest =
        n > 0 ? int(std::max_element(comp_area_.begin(), comp_area_.end()) - comp_area_.begin())
              : -1;
    comp_keep_.assign(n, 0);
    if (largest >= 0) comp_keep_[largest] = 1;
    for (int v = 0; v < nv; ++v) {
      if (Seam(v) && comp_of_[v] >= 0) comp_keep_[comp_of_[v]] = 1;
    }
    // Distance of each component (its area centroid) to the largest one's vertices (the
    // input's, in a region).
    comp_distance_.assign(n, 0.0);
    if (n > 1 && options_.component_deletion_factor > 0) {
      std::unique_ptr<PointTree> own;
      const PointTree* tree = largest_tree_;
      if (!tree) {
        std::vector<Eigen::Vector3d> main;
        for (int i = comp_start_[largest]; i < comp_start_[largest + 1]; ++i) {
          main.push_back(pos_[comp_vertices_[i]]);
        }
        own = std::make_unique<PointTree>(std::move(main));
        tree = own.get();
      }
      for (int c = 0; c < n; ++c) {
        if (!comp_keep_[c]) comp_distance_[c] = tree->Nearest(centroid[c]);
      }
    }
  }

  // The error estimate of deleting component c, mm: component_deletion_factor times the
  // geometric mean of its diagonal and its distance to the largest component (at least
  // the diagonal). Far floaters are dearer: deleting them leaves original surface far
  // from any output surface.
  double DeletionError(int c) const {
    return options_.component_deletion_factor *
           std::sqrt(comp_diag_[c] * std::max(comp_diag_[c], comp_distance_[c]));
  }

  // Queues the deletion of every live component but the largest, at the cost of moving
  // its whole area by its error estimate (the units of a collapse's quadric cost).
  void QueueComponentDeletions(bool heaped) {
    if (!(options_.component_deletion_factor > 0)) return;
    const int n_edges = int(edge_.size());
    for (int c = 0; c < int(comp_live_.size()); ++c) {
      if (comp_keep_[c] || comp_live_[c] == 0) continue;
      const double e = DeletionError(c);
      const float cost = float(comp_area_[c] * e * e);
      if (heaped) {
        heap_.Set(n_edges + c, cost);
      } else {
        heap_.Append(n_edges + c, cost);
      }
    }
  }

  // Deletes component c unless that would go below the target or the error bound.
  bool DeleteComponent(int c, int64_t target) {
    if (comp_live_[c] == 0 || live_ - comp_live_[c] < target) return false;
    if (options_.max_error_mm > 0 && DeletionError(c) > options_.max_error_mm) return false;
    for (int i = comp_start_[c]; i < comp_start_[c + 1]; ++i) {
      const int v = comp_vertices_[i];
      if (!alive_[v]) continue;
      for (int f : vfaces_[v]) {
        if (face_alive_[f]) face_alive_[f] = 0, --live_;
      }
      vfaces_.Clear(v);
      alive_[v] = 0;
    }
    triangles_deleted_ += comp_live_[c];
    ++components_deleted_;
    comp_live_[c] = 0;
    return true;
  }

  // Border vertices (on an edge used by one face) and locked ones: non-manifold edges or
  // fans, and with lock_border the border. Adds the border penalty planes.
  void ClassifyVertices() {
    const bool penalty = border_planes_ && !options_.lock_border && options_.border_weight > 0;
    for (size_t u = 0; u < vfaces_.size(); ++u) {
      if (vfaces_[u].empty()) continue;
      const uint32_t epoch = ++epoch_;
      int edges = 0, border_edges = 0;
      bool non_manifold = false;
      for (int f : vfaces_[u]) {
        for (int m = 0; m < 3; ++m) {
          const int w = faces_[f][m];
          if (w == int(u)) continue;
          if (marks_[w].u_epoch != epoch) {
            marks_[w].u_epoch = epoch;
            marks_[w].count_u = 0;
            ++edges;
          }
          ++marks_[w].count_u;
        }
      }
      for (int f : vfaces_[u]) {
        for (int m = 0; m < 3; ++m) {
          const int w = faces_[f][m];
          if (w == int(u) || marks_[w].u_epoch != epoch) continue;
          marks_[w].u_epoch = epoch - 1;  // count each neighbour once
          if (marks_[w].count_u > 2) non_manifold = true;
          if (marks_[w].count_u != 1) continue;
          ++border_edges;
          // A region's seam (two seam vertices) is no border of the input: the planes of
          // the input borders between seam vertices were added before it was cut.
          if (penalty && int(u) < w && !(Seam(int(u)) && Seam(w))) {
            // A seam vertex's other border edges are in this region only.
            AddBorderPlane(pos_, faces_[f], int(u), w, options_.border_weight,
                           {&quad_[u], &quad_[size_t(w)], Seam(int(u)) ? &absorbed_[u] : nullptr,
                            Seam(w) ? &absorbed_[size_t(w)] : nullptr});
          }
        }
      }
      ++epoch_;  // the marks above used epoch - 1; keep later epochs fresh
      const int nf = int(vfaces_[u].size());
      border_[u] = border_edges > 0;
      const bool fan_ok = border_edges == 0 ? edges == nf : (border_edges == 2 && edges == nf + 1);
      locked_[u] = non_manifold || !fan_ok || (options_.lock_border && border_[u]) || Seam(int(u));
    }
  }

  // The quadric-optimal position for merging a and b (the locked one's if one is).
  Eigen::Vector3d Placement(const Quadric& q, int keep, int gone) const {
    const Eigen::Vector3d& p = pos_[keep];
    const Eigen::Vector3d& r = pos_[gone];
    if (locked_[keep]) return p;
    const Eigen::Vector3d mid = 0.5 * (p + r);
    const Eigen::Matrix3d a = q.A();
    const Eigen::Vector3d g = a * mid + q.B();  // half the gradient at the midpoint
    Eigen::Vector3d x = mid;
    const double trace = a.trace();
    if (a.determinant() > kDirectFloor * trace * trace * trace) {
      // Well conditioned (the smallest eigenvalue is above kDirectFloor of the largest):
      // the eigen solution below would use all three directions; invert directly.
      x -= a.inverse() * g;
    } else {
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
      eig.computeDirect(a);
      const Eigen::Vector3d lambda = eig.eigenvalues();
      const double top = lambda.maxCoeff();
      if (top > 0) {
        for (int k = 0; k < 3; ++k) {
          if (lambda[k] > kEigenFloor * top) {
            const Eigen::Vector3d e = eig.eigenvectors().col(k);
            x -= e * (e.dot(g) / lambda[k]);
          }
        }
      }
    }
    // An optimum far off the edge comes from a nearly singular system: take the best of
    // the endpoints and the midpoint instead.
    if ((x - mid).squaredNorm() > (r - p).squaredNorm() || !x.allFinite()) {
      x = mid;
      double best = q.Eval(mid);
      for (const Eigen::Vector3d* c : {&p, &r}) {
        const double e = q.Eval(*c);
        if (e < best) best = e, x = *c;
      }
    }
    return x;
  }

  // How far the new faces of a collapse of v into u at x stray from the surface before,
  // mm: the largest distance of points of the faces around x (centroids and midpoints of
  // the edges from x) to the faces around u and v before the collapse. It sees what the
  // quadrics cannot, which measure the vertex only: a face spanning a gap between the
  // fingers of a ragged border, or cutting across a fold. (Measuring the other way too,
  // old vertices to the new faces, also charges a border for retreating, which costs
  // accuracy on stereo meshes, whose ragged borders should straighten.)
  double Deviation(int u, int v, const Eigen::Vector3d& x) {
    old_tris_.clear();
    old_balls_.clear();
    new_tris_.clear();
    new_from_.clear();
    new_ring_.clear();
    midpoints_done_.clear();
    for (int s : {u, v}) {
      for (int f : vfaces_[s]) {
        const auto& t = faces_[f];
        const bool has_u = t[0] == u || t[1] == u || t[2] == u;
        const bool has_v = t[0] == v || t[1] == v || t[2] == v;
        if (s == v && has_u) continue;  // listed with u already
        std::array<Eigen::Vector3d, 3> p;
        int at = 0;
        for (int m = 0; m < 3; ++m) {
          p[m] = pos_[t[m]];
          if (t[m] == u || t[m] == v) at = m;
        }
        old_tris_.push_back(p);
        // A ball around the face (centred on its centroid) for the distance bound below.
        const Eigen::Vector3d centre = (p[0] + p[1] + p[2]) / 3.0;
        old_balls_.push_back({centre, std::sqrt(std::max({(p[0] - centre).squaredNorm(),
                                                          (p[1] - centre).squaredNorm(),
                                                          (p[2] - centre).squaredNorm()}))});
        if (has_u && has_v) continue;  // removed by the collapse
        // Rotated so that x comes first; with the face it was and its other corners.
        new_tris_.push_back({{x, p[(at + 1) % 3], p[(at + 2) % 3]}});
        new_from_.push_back(int(old_tris_.size()) - 1);
        new_ring_.push_back({t[(at + 1) % 3], t[(at + 2) % 3]});
      }
    }
    // The points: the centroids and the midpoints of the edges from x (those on the
    // border too), each midpoint once (two new faces share each edge from x: the same
    // point), each with its distance to the face it came from, usually the nearest.
    points_.clear();
    for (size_t i = 0; i < new_tris_.size(); ++i) {
      const auto& t = new_tris_[i];
      const auto& o = old_tris_[new_from_[i]];
      const auto add = [&](const Eigen::Vector3d& p) {
        points_.push_back({PointTriangleDistance2(p, o[0], o[1], o[2]), p});
      };
      add((t[0] + t[1] + t[2]) / 3.0);
      for (int k = 0; k < 2; ++k) {
        const int corner = new_ring_[i][size_t(k)];
        if (std::find(midpoints_done_.begin(), midpoints_done_.end(), corner) !=
            midpoints_done_.end()) {
          continue;
        }
        midpoints_done_.push_back(corner);
        add(0.5 * (t[0] + t[size_t(k) + 1]));
      }
    }
    // The largest of the points' least distances to the old faces. Farthest from its own
    // face first: a point's least distance is at most that one, so once it is within the
    // largest found, so are all the points after it. The same maximum as in any order.
    std::sort(points_.begin(), points_.end(),
              [](const DeviationPoint& a, const DeviationPoint& b) { return a.own2 > b.own2; });
    double worst2 = 0;
    for (const DeviationPoint& point : points_) {
      if (!(point.own2 > worst2)) break;
      const Eigen::Vector3d& p = point.p;
      double best = point.own2;
      double reach = std::sqrt(best);
      for (size_t k = 0; k < old_tris_.size(); ++k) {
        // Skipped when no point of the face's ball is nearer than `best`: the distance
        // to the face is at least the centre's distance less the radius, compared
        // squared (no root a face) with a margin far above the rounding of either, so
        // the minimum is the same as without the test.
        const Ball& ball = old_balls_[k];
        const double limit = ball.radius + reach;
        if ((p - ball.centre).squaredNorm() > limit * limit * (1.0 + 1e-9)) continue;
        const double d2 =
            PointTriangleDistance2(p, old_tris_[k][0], old_tris_[k][1], old_tris_[k][2]);
        if (d2 < best) {
          best = d2;
          if (!(best > worst2)) break;
          reach = std::sqrt(best);
        }
      }
      worst2 = std::max(worst2, best);
    }
    return std::sqrt(worst2);
  }

  // Link condition: the collapse of v into u leaves a 2-manifold with the same topology
  // (open borders counted as joined to one virtual vertex). Then NothingFlips; a collapse
  // is made only when both hold.
  bool LinkHolds(int u, int v) {
    const uint32_t epoch = ++epoch_;
    int opposite[2] = {-1, -1}, n_opposite = 0;
    for (int f : vfaces_[u]) {
      const auto& t = faces_[f];
      bool has_v = false;
      for (int m = 0; m < 3; ++m) {
        const int w = t[m];
        if (w == v) has_v = true;
        if (w == u) continue;
        if (marks_[w].u_epoch != epoch) marks_[w].u_epoch = epoch, marks_[w].count_u = 0;
        ++marks_[w].count_u;
      }
      if (has_v) {
        if (n_opposite == 2) return false;  // a non-manifold edge
        opposite[n_opposite++] =
            t[0] != u && t[0] != v ? t[0] : (t[1] != u && t[1] != v ? t[1] : t[2]);
      }
    }
    if (n_opposite == 0) return false;
    int common = 0;
    for (int f : vfaces_[v]) {
      for (int m = 0; m < 3; ++m) {
        const int w = faces_[f][m];
        if (w == v) continue;
        if (marks_[w].v_epoch != epoch) {
          marks_[w].v_epoch = epoch, marks_[w].count_v = 0;
          if (w != u && marks_[w].u_epoch == epoch) ++common;
          // A new edge between two seam vertices: another region may make the same
          // edge, and the joined mesh would have it four times.
          if (w != u && marks_[w].u_epoch != epoch && Seam(u) && Seam(w)) return false;
        }
        ++marks_[w].count_v;
      }
    }
    if (common != n_opposite) return false;
    if (n_opposite == 1) {
      const int a = opposite[0];
      if (marks_[a].count_u == 1 && marks_[a].count_v == 1)
        return false;  // a lone triangle or an ear
    } else {
      if (border_[u] && border_[v]) return false;  // would pinch the border
      // Both u-a-b and v-a-b present: a tetrahedron, which would fold flat.
      const int a = opposite[0], b = opposite[1];
      auto has_face = [&](int s, int skip) {
        for (int f : vfaces_[s]) {
          const auto& t = faces_[f];
          const bool ha = t[0] == a || t[1] == a || t[2] == a;
          const bool hb = t[0] == b || t[1] == b || t[2] == b;
          const bool hs = t[0] == skip || t[1] == skip || t[2] == skip;
          if (ha && hb && !hs) return true;
        }
        return false;
      };
      if (has_face(u, v) && has_face(v, u)) return false;
    }
    return true;
  }

  // No triangle around u and v flipped or made degenerate by moving them to x. (A
  // triangle-quality bound was tried and cost accuracy: 0.324 against 0.303 mm mean
  // distance at 10% on a fused mesh.)
  bool NothingFlips(int u, int v, const Eigen::Vector3d& x) {
    for (int s : {u, v}) {
      for (int f : vfaces_[s]) {
        const auto& t = faces_[f];
        Eigen::Vector3d p[3], q[3];
        bool both = false;
        for (int m = 0; m < 3; ++m) {
          p[m] = pos_[t[m]];
          q[m] = t[m] == u || t[m] == v ? x : p[m];
          if ((t[m] == u && s == v) || (t[m] == v && s == u)) both = true;
        }
        if (both) continue;  // removed by the collapse
        const Eigen::Vector3d n_old = (p[1] - p[0]).cross(p[2] - p[0]);
        const Eigen::Vector3d n_new = (q[1] - q[0]).cross(q[2] - q[0]);
        const double len_new = n_new.norm(), len_old = n_old.norm();
        if (!(len_new > 0)) return false;
        if (len_old > 0 && n_new.dot(n_old) < kMinNormalCos * len_new * len_old) return false;
      }
    }
    return true;
  }

  // Collapses v into u at x. Of the removed faces' edges, u-v and v-a (a the opposite
  // corner) go, v-a's other face taking u-a's id; v's other edges become u's; every edge
  // of u then has its cost recomputed in place (queued again if it was refused).
  void Collapse(int u, int v, const Eigen::Vector3d& x) {
    const Eigen::Vector3d e = pos_[v] - pos_[u];
    const double e2 = e.squaredNorm();
    const float t = e2 > 0 ? float(std::clamp((x - pos_[u]).dot(e) / e2, 0.0, 1.0)) : 0.5f;
    if (!colors_.empty()) colors_[u] += t * (colors_[v] - colors_[u]);
    if (!normals_.empty()) normals_[u] += t * (normals_[v] - normals_[u]);
    if (!alphas_.empty()) alphas_[u] += t * (alphas_[v] - alphas_[u]);
    int merged_from[2] = {-1, -1}, merged_to[2] = {-1, -1}, n_merged = 0;
    for (int f : vfaces_[v]) {
      auto& tri = faces_[f];
      if (tri[0] == u || tri[1] == u || tri[2] == u) {
        face_alive_[f] = 0;
        --live_;
        --comp_live_[comp_of_[u]];
        int from = -1, to = -1;
        for (int m = 0; m < 3; ++m) {
          const int a = tri[m], b = tri[(m + 1) % 3], id = face_edges_[f][m];
          const bool has_u = a == u || b == u, has_v = a == v || b == v;
          if (has_u && has_v) {
            Kill(id);
          } else if (has_v) {
            from = id;
          } else {
            to = id;
          }
          if (a != u && a != v) vfaces_.Remove(a, f);
        }
        if (from >= 0 && n_merged < 2) {
          Kill(from);
          merged_from[n_merged] = from, merged_to[n_merged] = to, ++n_merged;
        }
      } else {
        for (int m = 0; m < 3; ++m) {
          if (tri[m] == v) tri[m] = u;
        }
        vfaces_.Add(u, f);
      }
    }
    vfaces_.RemoveIf(u, [&](int f) { return !face_alive_[f]; });
    vfaces_.Clear(v);
    pos_[u] = x;
    quad_[u] += quad_[v];
    if (Seam(u)) absorbed_[size_t(u)] += quad_[v];
    border_[u] = border_[u] || border_[v];
    alive_[v] = 0;
    const uint32_t epoch = ++epoch_;
    for (int f : vfaces_[u]) {
      for (int m = 0; m < 3; ++m) {
        int& id = face_edges_[f][m];
        for (int k = 0; k < n_merged; ++k) {
          if (id == merged_from[k]) id = merged_to[k];
        }
        const int a = faces_[f][m], b = faces_[f][(m + 1) % 3];
        if (a != u && b != u) continue;
        Edge& edge = edge_[id];
        if (edge.a == v) edge.a = u;
        if (edge.b == v) edge.b = u;
        if (edge_epoch_[id] == epoch) continue;  // each edge once
        edge_epoch_[id] = epoch;
        if (edge_state_[id] == kEdgeDead) continue;
        edge_state_[id] = kEdgeQueued;
        heap_.Set(id, EdgeCost(id));
      }
    }
  }

  bool Seam(int v) const { return !seam_.empty() && seam_[size_t(v)]; }

  void Kill(int id) {
    heap_.Remove(id);
    edge_state_[id] = kEdgeDead;
  }

  static constexpr int kMaxPasses = 8;
  // Relative floor of the quadric's eigenvalues below which a direction counts as
  // undetermined (the position stays at the midpoint along it).
  static constexpr double kEigenFloor = 1e-6;
  // det(A) above this times trace(A)^3 bounds the eigenvalue ratio above it (> kEigenFloor).
  static constexpr double kDirectFloor = 1e-5;
  static constexpr double kMinNormalCos = 0.0;  // refuse collapses turning a face > 90 deg
  // Deviations below this times the edge length count as none (rounding), dimensionless.
  static constexpr double kDeviationFloor = 1e-6;

  const DecimationOptions& options_;
  Eigen::Vector3d origin_;
  std::vector<Eigen::Vector3d> pos_;
  std::vector<Eigen::Vector3f> colors_, normals_;
  std::vector<float> alphas_;
  std::vector<uint8_t> seam_;  // CollapseInput::seam
  bool border_planes_;
  const PointTree* largest_tree_;
  std::vector<Quadric> quad_;
  // Per seam vertex, the quadrics of the vertices collapsed into it (the rest of its
  // quadric is the input's, which every region that shares it holds).
  std::vector<Quadric> absorbed_;
  std::vector<uint8_t> alive_, locked_, border_;
  FaceLists vfaces_;
  std::vector<Eigen::Vector3i> faces_;
  std::vector<uint8_t> face_alive_;
  // Per vertex, the link tests' marks (epochs) and counts of faces shared with u and v,
  // together: one cache line a neighbour instead of four.
  struct Marks {
    uint32_t u_epoch = 0, v_epoch = 0;
    int count_u = 0, count_v = 0;
  };
  std::vector<Marks> marks_;
  uint32_t epoch_ = 0;
  int64_t live_ = 0;
  double max_error_ = 0.0;
  // Edges: endpoints, state, whether the queued cost includes the deviation term, the
  // last collapse that recomputed it (an epoch); per face, its corners' edges.
  std::vector<Edge> edge_;
  std::vector<uint8_t> edge_state_, deviation_costed_;
  std::vector<uint32_t> edge_epoch_;
  std::vector<std::array<int, 3>> face_edges_;
  IndexedHeap heap_;  // edge ids, then edge count + component (deletions)
  // Deviation's scratch: the faces around the edge before and after, and for each after
  // the index of the face it was.
  std::vector<std::array<Eigen::Vector3d, 3>> old_tris_, new_tris_;
  struct Ball {
    Eigen::Vector3d centre;
    double radius;
  };
  std::vector<Ball> old_balls_;  // per old face: a ball holding it
  std::vector<int> new_from_;
  std::vector<std::array<int, 2>> new_ring_;  // per new face, its corners other than x
  std::vector<int> midpoints_done_;           // corners whose midpoint with x is measured
  struct DeviationPoint {
    double own2;        // squared distance to the face its new face came from
    Eigen::Vector3d p;  // a centroid or edge midpoint of a new face
  };
  std::vector<DeviationPoint> points_;
  // Components: per vertex (-1 when unused), live triangles, area (mm^2), bounding-box
  // diagonal (mm), vertices (CSR); the one with the largest area.
  std::vector<int> comp_of_, comp_live_, comp_start_, comp_vertices_;
  std::vector<double> comp_area_, comp_diag_, comp_distance_;
  std::vector<uint8_t> comp_keep_;  // never deleted (LabelComponents)
  int64_t components_deleted_ = 0, triangles_deleted_ = 0;
};

// meshoptimizer's topology-preserving simplification of `faces` towards
// `target_triangles`: the kept faces as index triples into mesh.vertices (it moves no
// vertex); *error_mm its error estimate.
std::vector<unsigned int> MeshoptimizerSimplify(const io::Mesh& mesh,
                                                const std::vector<Eigen::Vector3i>& faces,
                                                size_t target_triangles,
                                                const DecimationOptions& options,
                                                double* error_mm) {
  std::vector<unsigned int> indices(faces.size() * 3);
  for (size_t f = 0; f < faces.size(); ++f) {
    for (int m = 0; m < 3; ++m) indices[3 * f + m] = static_cast<unsigned int>(faces[f][m]);
  }
  const float* positions = mesh.vertices.empty() ? nullptr : mesh.vertices[0].data();
  float scale = 1.0f;
  if (!mesh.vertices.empty()) {
    scale = meshopt_simplifyScale(positions, mesh.vertices.size(), sizeof(Eigen::Vector3f));
  }
  const float target_error =
      options.max_error_mm > 0.0 && scale > 0.0f ? float(options.max_error_mm / scale) : 1e30f;
  std::vector<unsigned int> out(indices.size());
  float result_error = 0.0f;
  size_t n_out = 0;
  if (!indices.empty()) {
    n_out = meshopt_simplify(out.data(), indices.data(), indices.size(), positions,
                             mesh.vertices.size(), sizeof(Eigen::Vector3f), target_triangles * 3,
                             target_error, options.lock_border ? meshopt_SimplifyLockBorder : 0,
                             &result_error);
  }
  out.resize(n_out);
  *error_mm = double(result_error) * scale;
  return out;
}

io::Mesh MeshoptimizerDecimate(const io::Mesh& mesh, const std::vector<Eigen::Vector3i>& faces,
                               size_t target_triangles, const DecimationOptions& options,
                               double* error_mm) {
  const std::vector<unsigned int> out =
      MeshoptimizerSimplify(mesh, faces, target_triangles, options, error_mm);
  const size_t n_out = out.size();
  std::vector<Eigen::Vector3f> moved;
  if (options.relocate_vertices && n_out > 0) {
    io::Mesh kept = mesh;
    kept.faces = faces;
    moved = RelocatedPositions(kept, out);
  }
  io::Mesh result;
  std::vector<int> remap(mesh.vertices.size(), -1);
  for (size_t f = 0; f + 2 < out.size(); f += 3) {
    Eigen::Vector3i face;
    for (int m = 0; m < 3; ++m) {
      const unsigned int v = out[f + m];
      if (remap[v] < 0) {
        remap[v] = static_cast<int>(result.vertices.size());
        result.vertices.push_back(moved.empty() ? mesh.vertices[v] : moved[v]);
        if (mesh.HasNormals()) result.normals.push_back(mesh.normals[v]);
        if (mesh.HasColors()) result.colors.push_back(mesh.colors[v]);
        if (mesh.HasAlphas()) result.alphas.push_back(mesh.alphas[v]);
      }
      face[m] = remap[v];
    }
    result.faces.push_back(face);
  }
  return result;
}

// What the edge collapses made: the mesh and the summary's figures.
struct Collapsed {
  io::Mesh mesh;
  double error_mm = 0.0;
  int64_t components_deleted = 0, triangles_deleted = 0;
};

// Edge collapses of `in` to `target` faces in one pass.
Collapsed CollapseInOnePass(CollapseInput in, int64_t target, const DecimationOptions& options) {
  EdgeCollapser collapser(std::move(in), options);
  collapser.Run(target);
  Collapsed result;
  result.mesh = collapser.Result();
  result.error_mm = collapser.max_error_mm();
  result.components_deleted = collapser.components_deleted();
  result.triangles_deleted = collapser.triangles_deleted();
  return result;
}

// The most regions a decimation is split in (RegionCount).
constexpr int kMaxRegions = 64;

// How many regions to decimate `faces` in: the largest power of two (at most
// kMaxRegions) that leaves each region at least faces_per_region faces. A count of the
// faces only, never of the threads, so that the output is the same on every machine; a
// power of two so that the regions, of equal face counts, share out evenly over 1, 2, 4
// or 8 threads.
int RegionCount(size_t faces, int64_t faces_per_region) {
  if (faces_per_region <= 0) return 1;
  int regions = 1;
  while (regions < kMaxRegions && int64_t(faces) >= 2 * int64_t(regions) * faces_per_region) {
    regions *= 2;
  }
  return regions;
}

// The vertices of the largest connected component (by area) of `faces`, in a kd-tree:
// what the component deletions measure distances to (EdgeCollapser::LabelComponents).
PointTree LargestComponentTree(const std::vector<Eigen::Vector3d>& pos,
                               const std::vector<Eigen::Vector3i>& faces) {
  core::DisjointSets sets(pos.size());
  for (const auto& f : faces) {
    for (int m = 1; m < 3; ++m) sets.Union(f[0], f[m]);
  }
  std::vector<double> area(pos.size(), 0.0);
  for (const auto& f : faces) {
    area[size_t(sets.Find(f[0]))] +=
        0.5 *
        (pos[size_t(f[1])] - pos[size_t(f[0])]).cross(pos[size_t(f[2])] - pos[size_t(f[0])]).norm();
  }
  const int largest = int(std::max_element(area.begin(), area.end()) - area.begin());
  std::vector<uint8_t> used(pos.size(), 0);
  std::vector<Eigen::Vector3d> points;
  for (const auto& f : faces) {
    for (int m = 0; m < 3; ++m) {
      const int v = f[m];
      if (!used[size_t(v)] && sets.Find(v) == largest)
        points.push_back(pos[size_t(v)]), used[size_t(v)] = 1;
    }
  }
  return PointTree(std::move(points));
}

// A second round of CollapseInRegions (below) needs at least twice this many regions in
// the first, and cuts the joined mesh in the middle of every this-many-th of them.
constexpr int kRegionsPerGroup = 4;

// How CollapseInRegions cuts the faces: in slices along the longest axis of their
// bounding box at `slices`, increasing fractions of the face count in (0, 1); or, when
// kd_levels > 0, in 2^kd_levels boxes: the faces halved at the median of their centroids
// along the longest side of their bounding box, then each half likewise (a k-d tree).
struct RegionCut {
  int kd_levels = 0;
  std::vector<double> slices;
  // Slices give way to as many boxes when their seams hold more than 1 / kMaxSeamShare
  // of the faces (the first round; below).
  bool boxes_past_seam_share = false;
};

// The first round's slices give way to boxes when more than 1 / kMaxSeamShare of the
// faces lie on their seams. Each cut of a slice crosses the whole surface: on a Panoptic
// instant's 1.48 M faces, 64 slices left 48 % of the faces on a seam (locked in the
// regions: the first round ended at 771 k faces, and the serial last pass took 378 k
// faces to the target's 147 k), 64 boxes 11 % (`dome mesh decimate` 0.74-0.80x the wall,
// the same distances to the input). Below it slices stay: they leave more of the
// collapses to the passes over the whole surface, which choose the cheapest anywhere,
// where every region takes the same ratio (a Robovision surface, 358 k faces: 16 slices
// put 10 % of the faces on seams, 16 boxes 3 %, and the output lay 0.0198 mm from the
// input on average with boxes against 0.0161 with slices; templeSparseRing's 463 k
// faces in 16 slices: 15 %).
constexpr size_t kMaxSeamShare = 4;

// The faces of `in` in region order (each with its last sort key: the sum of its
// corners' coordinates along the axis it was cut on; ties by index), and in *bounds each
// region's first position in that order, then the face count. A fixed function of the
// faces, the same on any thread count.
std::vector<std::pair<double, int>> CutInRegions(const CollapseInput& in, const RegionCut& cut,
                                                 std::vector<size_t>* bounds) {
  const size_t nf = in.faces.size();
  auto key = [&](int f, int axis) {
    const auto& t = in.faces[size_t(f)];
    return in.pos[size_t(t[0])][axis] + in.pos[size_t(t[1])][axis] + in.pos[size_t(t[2])][axis];
  };
  // A box's axis: the longest side of its faces' centroids' bounding box.
  auto longest_axis = [&](const std::pair<double, int>* b, const std::pair<double, int>* e) {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(HUGE_VAL), hi = -lo;
    for (const auto* o = b; o != e; ++o) {
      const Eigen::Vector3d c(key(o->second, 0), key(o->second, 1), key(o->second, 2));
      lo = lo.cwiseMin(c);
      hi = hi.cwiseMax(c);
    }
    int axis = 0;
    (hi - lo).maxCoeff(&axis);
    return axis;
  };
  std::vector<std::pair<double, int>> order(nf);
  for (size_t f = 0; f < nf; ++f) order[f] = {0.0, int(f)};
  if (cut.kd_levels > 0) {
    bounds->assign({0, nf});
    for (int level = 0; level < cut.kd_levels; ++level) {
      std::vector<size_t> next{0};
      for (size_t r = 0; r + 1 < bounds->size(); ++r) {
        auto* b = order.data() + (*bounds)[r];
        auto* e = order.data() + (*bounds)[r + 1];
        const int axis = longest_axis(b, e);
        for (auto* o = b; o != e; ++o) o->first = key(o->second, axis);
        auto* mid = b + (e - b) / 2;
        std::nth_element(b, mid, e);
        next.push_back(size_t(mid - order.data()));
        next.push_back((*bounds)[r + 1]);
      }
      *bounds = std::move(next);
    }
    return order;
  }
  // The slices' axis: the longest side of the corners' bounding box.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(HUGE_VAL), hi = -lo;
  for (const auto& f : in.faces) {
    for (int m = 0; m < 3; ++m) {
      lo = lo.cwiseMin(in.pos[size_t(f[m])]);
      hi = hi.cwiseMax(in.pos[size_t(f[m])]);
    }
  }
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  for (auto& o : order) o.first = key(o.second, axis);
  const size_t regions = cut.slices.size() + 1;
  bounds->assign(regions + 1, nf);
  (*bounds)[0] = 0;
  for (size_t r = 1; r < regions; ++r) {
    (*bounds)[r] =
        std::clamp(size_t(std::llround(cut.slices[r - 1] * double(nf))), (*bounds)[r - 1], nf);
  }
  for (size_t r = 1; r < regions; ++r) {
    std::nth_element(order.begin() + ptrdiff_t((*bounds)[r - 1]),
                     order.begin() + ptrdiff_t((*bounds)[r]), order.end());
  }
  return order;
}

// Edge collapses of `in` to `target` faces in regions on num_threads threads, then over
// the joined regions. The faces are cut as `cut` says (CutInRegions: slices of equal
// face counts along the longest axis, sorted by centroid, ties by index; in the first
// round boxes instead when the slices' seams hold more than 1 / kMaxSeamShare of the
// faces); a vertex used by two regions is a seam vertex. Each region is decimated on its own, its
// seam vertices locked, its quadrics those of the input (each seam vertex's, in every region, all
// its input faces'), to the target's share of its faces away from the seam, its seam faces kept on
// top. The regions are joined by the seam vertices' indices (they did not move), each vertex
// keeping its quadric (a seam vertex's input quadric plus what each region collapsed
// into it).
// Second round (with 2 x kRegionsPerGroup regions or more): the joined mesh is cut again
// in slices, at (k G + G / 2 + 1 / 2) / regions (G = kRegionsPerGroup): in the middle of
// every G-th slice of the first round, so that the first round's seams lie inside the
// second's regions, where their faces are free (boxes' seams lie on planes of every axis
// at other places than these, so they too are mostly inside). `first_seam` marks the first round's
// seam vertices of the joined mesh (its face count `first_faces`): a second-round region's target
// takes off its faces on them (and on none of its own seam) to the first round's ratio, what the
// first round would have made of them, and leaves the rest of the region as it is. (Sharing the
// whole remaining reduction out instead, in proportion to those faces, collapsed too far in places:
// on a Robovision surface the mean distance to the input rose by two fifths.) Last, one pass over
// the whole joined mesh, seams free, takes it to the target: the seams' faces of the last round,
// and what the regions fell short of (with locked seams, a narrow region cannot always reach its
// share). That pass is serial; the second round spares it most of the first round's many seams.
// Every step is in a fixed order, so the output does not depend on the thread count.
Collapsed CollapseInRegions(CollapseInput in, const RegionCut& cut, int64_t target,
                            const DecimationOptions& options,
                            const std::vector<uint8_t>* first_seam = nullptr,
                            int64_t first_faces = 0) {
  const size_t nv = in.pos.size(), nf = in.faces.size();
  if (in.quadrics.empty()) in.quadrics = PlaneQuadrics(in.pos, in.faces);
  std::vector<size_t> bounds;
  std::vector<std::pair<double, int>> order = CutInRegions(in, cut, &bounds);
  int regions = int(bounds.size()) - 1;
  std::vector<int> region_of(nf);
  std::vector<uint8_t> seam(nv, 0);
  // The seam vertices (used by faces of two regions); returns the faces on them.
  auto mark_seams = [&] {
    for (int r = 0; r < regions; ++r) {
      for (size_t i = bounds[size_t(r)]; i < bounds[size_t(r) + 1]; ++i)
        region_of[size_t(order[i].second)] = r;
    }
    std::vector<int> first_region(nv, -1);
    std::fill(seam.begin(), seam.end(), 0);
    for (size_t f = 0; f < nf; ++f) {
      for (int m = 0; m < 3; ++m) {
        int& first = first_region[size_t(in.faces[f][m])];
        if (first < 0) first = region_of[f];
        if (first != region_of[f]) seam[size_t(in.faces[f][m])] = 1;
      }
    }
    size_t on_seam = 0;
    for (const auto& t : in.faces)
      on_seam += (seam[size_t(t[0])] | seam[size_t(t[1])] | seam[size_t(t[2])]) != 0;
    return on_seam;
  };
  if (mark_seams() > nf / kMaxSeamShare && cut.boxes_past_seam_share) {
    RegionCut boxes;
    while ((1 << boxes.kd_levels) < regions) ++boxes.kd_levels;
    order = CutInRegions(in, boxes, &bounds);
    regions = int(bounds.size()) - 1;
    mark_seams();
  }
  // The border planes of the input's border edges between two seam vertices (each
  // region sees every seam edge as a border, and leaves those edges to this).
  if (in.border_planes && !options.lock_border && options.border_weight > 0) {
    std::vector<std::array<int, 3>> edges;  // smaller end, larger end, face
    for (size_t f = 0; f < nf; ++f) {
      for (int m = 0; m < 3; ++m) {
        const int a = in.faces[f][m], b = in.faces[f][(m + 1) % 3];
        if (a != b && seam[size_t(a)] && seam[size_t(b)]) {
          edges.push_back({std::min(a, b), std::max(a, b), int(f)});
        }
      }
    }
    std::sort(edges.begin(), edges.end());
    for (size_t i = 0; i < edges.size();) {
      size_t j = i;
      while (j < edges.size() && edges[j][0] == edges[i][0] && edges[j][1] == edges[i][1]) ++j;
      if (j - i == 1) {
        AddBorderPlane(in.pos, in.faces[size_t(edges[i][2])], edges[i][0], edges[i][1],
                       options.border_weight,
                       {&in.quadrics[size_t(edges[i][0])], &in.quadrics[size_t(edges[i][1])]});
      }
      i = j;
    }
  }
  std::unique_ptr<PointTree> largest;
  if (options.component_deletion_factor > 0) {
    largest = std::make_unique<PointTree>(LargestComponentTree(in.pos, in.faces));
  }
  // The regions, each on the next free thread.
  const double ratio = nf > 0 ? double(target) / double(nf) : 1.0;
  const size_t n_regions = size_t(regions);
  std::vector<CollapseInput> out(n_regions);
  std::vector<std::vector<int>> global_of(n_regions);  // per exported vertex
  std::vector<Collapsed> figures(n_regions);
  std::atomic<int> next{0};
  const int threads = options.num_threads > 0 ? options.num_threads : core::HardwareThreads();
  core::ParallelFor(
      0, std::min(threads, regions), std::min(threads, regions), [&](int64_t, int64_t) {
        for (int r = next++; r < regions; r = next++) {
          std::vector<int> faces;
          for (size_t i = bounds[size_t(r)]; i < bounds[size_t(r) + 1]; ++i)
            faces.push_back(order[i].second);
          std::sort(faces.begin(), faces.end());  // the input's order: its locality
          CollapseInput part;
          part.origin = in.origin;
          part.border_planes = in.border_planes;
          part.largest = largest.get();
          std::vector<int> local(nv, -1), global;
          int64_t seam_faces = 0, first_seam_faces = 0;
          for (int f : faces) {
            Eigen::Vector3i t;
            bool on_seam = false, on_first_seam = false;
            for (int m = 0; m < 3; ++m) {
              const int g = in.faces[size_t(f)][m];
              if (local[size_t(g)] < 0) local[size_t(g)] = int(global.size()), global.push_back(g);
              t[m] = local[size_t(g)];
              on_seam = on_seam || seam[size_t(g)];
              on_first_seam = on_first_seam || (first_seam != nullptr && (*first_seam)[size_t(g)]);
            }
            seam_faces += on_seam;
            first_seam_faces += on_first_seam && !on_seam;
            part.faces.push_back(t);
          }
          const size_t n = global.size();
          part.pos.resize(n);
          part.quadrics.resize(n);
          part.seam.resize(n);
          if (!in.colors.empty()) part.colors.resize(n);
          if (!in.normals.empty()) part.normals.resize(n);
          if (!in.alphas.empty()) part.alphas.resize(n);
          for (size_t i = 0; i < n; ++i) {
            const size_t g = size_t(global[i]);
            part.pos[i] = in.pos[g];
            part.quadrics[i] = in.quadrics[g];
            part.seam[i] = seam[g];
            if (!in.colors.empty()) part.colors[i] = in.colors[g];
            if (!in.normals.empty()) part.normals[i] = in.normals[g];
            if (!in.alphas.empty()) part.alphas[i] = in.alphas[g];
          }
          EdgeCollapser collapser(std::move(part), options);
          // First round: the target's share of the faces off the seam, the seam's kept.
          // Second: the first round's ratio taken off its seams' faces, the rest kept.
          const double first_ratio = first_faces > 0 ? double(target) / double(first_faces) : ratio;
          collapser.Run(first_seam != nullptr
                            ? int64_t(faces.size()) -
                                  std::llround((1.0 - first_ratio) * double(first_seam_faces))
                            : std::llround(ratio * double(int64_t(faces.size()) - seam_faces)) +
                                  seam_faces);
          std::vector<int> used;
          collapser.Export(&used, &out[size_t(r)]);
          for (int& v : used) v = global[size_t(v)];
          global_of[size_t(r)] = std::move(used);
          figures[size_t(r)].error_mm = collapser.max_error_mm();
          figures[size_t(r)].components_deleted = collapser.components_deleted();
          figures[size_t(r)].triangles_deleted = collapser.triangles_deleted();
        }
      });
  // Joined: each seam vertex once (where first met), with its input quadric and what
  // every region collapsed into it.
  CollapseInput joined;
  joined.origin = in.origin;
  joined.border_planes = false;  // the quadrics carry them
  std::vector<int> joined_of(nv, -1);
  std::vector<uint8_t> joined_seam;  // per joined vertex: a seam vertex of this round
  for (int r = 0; r < regions; ++r) {
    const CollapseInput& part = out[size_t(r)];
    std::vector<int> index(part.pos.size());
    for (size_t i = 0; i < part.pos.size(); ++i) {
      const size_t g = size_t(global_of[size_t(r)][i]);
      if (seam[g] && joined_of[g] >= 0) {
        joined.quadrics[size_t(joined_of[g])] += part.quadrics[i];
        index[i] = joined_of[g];
        continue;
      }
      index[i] = int(joined.pos.size());
      if (seam[g]) {
        joined_of[g] = index[i];
        joined.quadrics.push_back(in.quadrics[g]);
        joined.quadrics.back() += part.quadrics[i];
      } else {
        joined.quadrics.push_back(part.quadrics[i]);
      }
      joined.pos.push_back(part.pos[i]);
      joined_seam.push_back(seam[g]);
      if (!part.colors.empty()) joined.colors.push_back(part.colors[i]);
      if (!part.normals.empty()) joined.normals.push_back(part.normals[i]);
      if (!part.alphas.empty()) joined.alphas.push_back(part.alphas[i]);
    }
    for (const auto& t : part.faces)
      joined.faces.emplace_back(index[size_t(t[0])], index[size_t(t[1])], index[size_t(t[2])]);
  }
  out.clear();
  Collapsed result;
  if (first_seam == nullptr && regions >= 2 * kRegionsPerGroup) {
    RegionCut again;
    for (int k = 0; kRegionsPerGroup * k + kRegionsPerGroup / 2 < regions; ++k)
      again.slices.push_back((kRegionsPerGroup * k + kRegionsPerGroup / 2 + 0.5) / regions);
    result =
        CollapseInRegions(std::move(joined), again, target, options, &joined_seam, int64_t(nf));
  } else {
    result = CollapseInOnePass(std::move(joined), target, options);
  }
  for (const Collapsed& f : figures) {
    result.error_mm = std::max(result.error_mm, f.error_mm);
    result.components_deleted += f.components_deleted;
    result.triangles_deleted += f.triangles_deleted;
  }
  return result;
}

// Edge collapses of `in` to `target` faces: in regions when it is large enough
// (RegionCount), else in one pass.
Collapsed Collapse(CollapseInput in, int64_t target, const DecimationOptions& options) {
  const int regions = RegionCount(in.faces.size(), options.faces_per_region);
  if (regions > 1) {
    RegionCut slices;
    for (int r = 1; r < regions; ++r) slices.slices.push_back(double(r) / regions);
    slices.boxes_past_seam_share = true;
    return CollapseInRegions(std::move(in), slices, target, options);
  }
  return CollapseInOnePass(std::move(in), target, options);
}

}  // namespace

void DecimationOptions::Check() const {
  core::Require(target_triangles >= 0, "decimation: target_triangles",
                "must be >= 0, got " + std::to_string(target_triangles));
  core::Require(std::isfinite(target_ratio) && target_ratio > 0.0 && target_ratio <= 1.0,
                "decimation: target_ratio",
                "must be in (0, 1], got " + std::to_string(target_ratio));
  core::Require(std::isfinite(max_error_mm) && max_error_mm >= 0.0, "decimation: max_error_mm",
                "must be >= 0 mm, got " + std::to_string(max_error_mm));
  core::Require(std::isfinite(border_weight) && border_weight >= 0.0, "decimation: border_weight",
                "must be >= 0, got " + std::to_string(border_weight));
  core::Require(min_component_triangles >= 0, "decimation: min_component_triangles",
                "must be >= 0, got " + std::to_string(min_component_triangles));
  core::Require(std::isfinite(min_component_diagonal_mm) && min_component_diagonal_mm >= 0.0,
                "decimation: min_component_diagonal_mm",
                "must be >= 0 mm, got " + std::to_string(min_component_diagonal_mm));
  core::Require(std::isfinite(deviation_weight) && deviation_weight >= 0.0,
                "decimation: deviation_weight",
                "must be >= 0, got " + std::to_string(deviation_weight));
  core::Require(
      std::isfinite(deviation_from_factor) &&
          (deviation_from_factor == 0.0 || deviation_from_factor >= 1.0),
      "decimation: deviation_from_factor",
      "must be 0 (from the first collapse) or >= 1, got " + std::to_string(deviation_from_factor));
  core::Require(
      std::isfinite(speck_area_fraction) && speck_area_fraction >= 0.0 && speck_area_fraction < 1.0,
      "decimation: speck_area_fraction",
      "must be in [0, 1), got " + std::to_string(speck_area_fraction));
  core::Require(std::isfinite(speck_diagonal_mm) && speck_diagonal_mm >= 0.0,
                "decimation: speck_diagonal_mm",
                "must be >= 0 mm, got " + std::to_string(speck_diagonal_mm));
  core::Require(std::isfinite(speck_gap_mm) && speck_gap_mm >= 0.0, "decimation: speck_gap_mm",
                "must be >= 0 mm, got " + std::to_string(speck_gap_mm));
  core::Require(std::isfinite(prepass_factor) && (prepass_factor == 0.0 || prepass_factor > 1.0),
                "decimation: prepass_factor",
                "must be 0 (none) or > 1, got " + std::to_string(prepass_factor));
  core::Require(faces_per_region >= 0, "decimation: faces_per_region",
                "must be >= 0, got " + std::to_string(faces_per_region));
  core::Require(std::isfinite(component_deletion_factor) && component_deletion_factor >= 0.0,
                "decimation: component_deletion_factor",
                "must be >= 0, got " + std::to_string(component_deletion_factor));
}

io::Mesh Decimate(const io::Mesh& mesh, const DecimationOptions& options,
                  DecimationSummary* summary) {
  options.Check();
  const std::string bad = mesh.Inconsistency();
  core::Require(bad.empty(), "decimation: mesh", bad);
  core::Stopwatch watch;
  const size_t triangles = mesh.faces.size();
  const int64_t target_triangles =
      options.target_triangles > 0
          ? options.target_triangles
          : int64_t(std::llround(options.target_ratio * double(triangles)));
  ComponentFilter filter;
  filter.min_triangles = options.min_component_triangles;
  filter.min_diagonal_mm = options.min_component_diagonal_mm;
  filter.speck_area_fraction = options.speck_area_fraction;
  filter.speck_diagonal_mm = options.speck_diagonal_mm;
  filter.speck_gap_mm = options.speck_gap_mm;
  const std::vector<Eigen::Vector3i> faces =
      options.min_component_triangles > 0 || options.min_component_diagonal_mm > 0 ||
              (options.speck_area_fraction > 0 && options.speck_diagonal_mm > 0)
          ? KeptComponentFaces(mesh, &filter, options.num_threads)
          : mesh.faces;
  io::Mesh result;
  double error_mm = 0.0;
  int64_t components_deleted = 0, triangles_deleted = 0;
  if (options.method == DecimationMethod::kMeshoptimizer) {
    result = MeshoptimizerDecimate(mesh, faces, size_t(target_triangles), options, &error_mm);
  } else {
    CollapseInput in = InputFromMesh(mesh, faces);
    if (options.prepass_factor > 0 &&
        double(faces.size()) > options.prepass_factor * double(target_triangles)) {
      // meshoptimizer's pass to prepass_factor x the target, its kept vertices carrying
      // the input's quadrics, then the edge collapses to the target.
      const std::vector<unsigned int> kept = MeshoptimizerSimplify(
          mesh, faces, size_t(std::llround(options.prepass_factor * double(target_triangles))),
          options, &error_mm);
      in.faces.resize(kept.size() / 3);
      for (size_t f = 0; f < in.faces.size(); ++f) {
        in.faces[f] = Eigen::Vector3i(int(kept[3 * f]), int(kept[3 * f + 1]), int(kept[3 * f + 2]));
      }
      in.quadrics = ClusterQuadrics(mesh, faces, kept);
    }
    Collapsed collapsed = Collapse(std::move(in), target_triangles, options);
    result = std::move(collapsed.mesh);
    error_mm = std::max(error_mm, collapsed.error_mm);
    components_deleted = collapsed.components_deleted;
    triangles_deleted = collapsed.triangles_deleted;
  }
  if (summary) {
    summary->triangles_in = int64_t(triangles);
    summary->triangles_out = int64_t(result.faces.size());
    summary->components_removed = filter.removed;
    summary->triangles_removed = int64_t(triangles - faces.size()) - filter.speck_triangles;
    summary->specks_removed = filter.specks;
    summary->speck_triangles = filter.speck_triangles;
    summary->components_deleted = components_deleted;
    summary->triangles_deleted = triangles_deleted;
    summary->error_mm = error_mm;
    summary->seconds = watch.ElapsedSeconds();
  }
  return result;
}

}  // namespace dome::mesh
