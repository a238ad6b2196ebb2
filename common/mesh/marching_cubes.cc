#include "mesh/marching_cubes.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <unordered_map>

#include "core/error.h"

namespace dome::mesh {
namespace {

// Least distance of a vertex from either end of its edge, in edges (1e-3 of a voxel:
// far below the 0.01 voxel the surface is tested to, and hundreds of float steps).
constexpr double kEdgeMargin = 1e-3;

// Corner c of a cell is at offset (c & 1, (c >> 1) & 1, (c >> 2) & 1).
constexpr std::array<std::array<int, 2>, 12> kEdgeCorners = {{{0, 1},
                                                              {2, 3},
                                                              {4, 5},
                                                              {6, 7},
                                                              {0, 2},
                                                              {1, 3},
                                                              {4, 6},
                                                              {5, 7},
                                                              {0, 4},
                                                              {1, 5},
                                                              {2, 6},
                                                              {3, 7}}};

int EdgeOf(int a, int b) {
  for (int e = 0; e < 12; ++e) {
    if ((kEdgeCorners[e][0] == a && kEdgeCorners[e][1] == b) ||
        (kEdgeCorners[e][0] == b && kEdgeCorners[e][1] == a)) {
      return e;
    }
  }
  return -1;
}

Eigen::Vector3d CornerPos(int c) { return Eigen::Vector3d(c & 1, (c >> 1) & 1, (c >> 2) & 1); }

// The cube faces (as corner sets) an edge lies on: bit f set for face f of
// {x=0, x=1, y=0, y=1, z=0, z=1}.
int EdgeFaces(int e) {
  const int a = kEdgeCorners[e][0], b = kEdgeCorners[e][1];
  int faces = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const int ba = (a >> axis) & 1, bb = (b >> axis) & 1;
    if (ba == bb) faces |= 1 << (2 * axis + ba);
  }
  return faces;
}

// Triangulates a contour loop (cube edges in order) so that no diagonal joins two
// vertices on a common cube face: such a chord would lie in the face and could be
// produced by the neighbouring cell too (a non-manifold edge). Recursive over the
// triangle on the loop's first side; loops have at most 12 vertices.
bool Triangulate(const std::vector<int>& loop, std::vector<std::array<int, 3>>* out) {
  const size_t n = loop.size();
  if (n < 3) return n == 0;
  if (n == 3) {
    out->push_back({loop[0], loop[1], loop[2]});
    return true;
  }
  auto chord_ok = [&](size_t a, size_t b) {
    const size_t d = (b + n - a) % n;
    if (d == 1 || d == n - 1) return true;  // a side of the loop
    return (EdgeFaces(loop[a]) & EdgeFaces(loop[b])) == 0;
  };
  // Triangle (0, 1, k): sub-loops [1..k] and [k..n-1, 0].
  for (size_t k = 2; k < n; ++k) {
    if (!chord_ok(1, k) || !chord_ok(k, 0)) continue;
    std::vector<int> left(loop.begin() + 1, loop.begin() + k + 1);
    std::vector<int> right(loop.begin() + k, loop.end());
    right.push_back(loop[0]);
    std::vector<std::array<int, 3>> tris = {{loop[0], loop[1], loop[k]}};
    if ((left.size() < 3 || Triangulate(left, &tris)) &&
        (right.size() < 3 || Triangulate(right, &tris))) {
      out->insert(out->end(), tris.begin(), tris.end());
      return true;
    }
  }
  return false;
}

// Triangles (as edge triples) of each of the 256 sign cases, built from the faces.
struct CaseTable {
  std::array<std::vector<std::array<int, 3>>, 256> triangles;

  CaseTable() {
    // The six faces, corners in cyclic order, oriented counter-clockwise seen from
    // outside the cell (fixed below by the outward normal).
    std::array<std::array<int, 4>, 6> faces = {
        {{0, 2, 6, 4}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 5, 7, 6}}};
    const Eigen::Vector3d centre(0.5, 0.5, 0.5);
    for (auto& f : faces) {
      const Eigen::Vector3d p0 = CornerPos(f[0]), p1 = CornerPos(f[1]), p2 = CornerPos(f[2]);
      const Eigen::Vector3d n = (p1 - p0).cross(p2 - p1);
      const Eigen::Vector3d out = (p0 + p2) / 2 - centre;
      if (n.dot(out) < 0) std::reverse(f.begin(), f.end());
    }
    bool flip = false;
    for (int pass = 0; pass < 2; ++pass) {
      for (int code = 0; code < 256; ++code) {
        auto inside = [&](int c) { return (code >> c) & 1; };
        std::array<int, 12> next;
        next.fill(-1);
        for (const auto& f : faces) {
          // Crossings around the face in order; pair each entering crossing (outside ->
          // inside) with the following leaving one: each run of inside corners is cut
          // off on its own.
          int enter = -1;
          int first_leave = -1;
          for (int m = 0; m < 4; ++m) {
            const int a = f[m], b = f[(m + 1) % 4];
            if (inside(a) == inside(b)) continue;
            const int e = EdgeOf(a, b);
            if (!inside(a)) {
              enter = e;
            } else if (enter >= 0) {
              next[enter] = e;
              enter = -1;
            } else {
              first_leave = e;
            }
          }
          if (enter >= 0) next[enter] = first_leave;
        }
        auto& tris = triangles[code];
        tris.clear();
        std::array<bool, 12> used{};
        for (int e = 0; e < 12; ++e) {
          if (next[e] < 0 || used[e]) continue;
          std::vector<int> loop;
          for (int x = e; !used[x]; x = next[x]) {
            used[x] = true;
            loop.push_back(x);
          }
          std::vector<std::array<int, 3>> loop_tris;
          const bool ok = Triangulate(loop, &loop_tris);
          DOME_CHECK(ok, "marching cubes: a contour loop has no valid triangulation");
          for (const auto& t : loop_tris) {
            tris.push_back(flip ? std::array<int, 3>{t[0], t[2], t[1]} : t);
          }
        }
      }
      if (pass == 0) {
        // Case 1 (only corner 0 inside): the normal must point away from corner 0.
        const auto& t = triangles[1][0];
        auto mid = [](int e) -> Eigen::Vector3d {
          return (CornerPos(kEdgeCorners[e][0]) + CornerPos(kEdgeCorners[e][1])) / 2;
        };
        const Eigen::Vector3d n = (mid(t[1]) - mid(t[0])).cross(mid(t[2]) - mid(t[0]));
        if (n.dot(Eigen::Vector3d(1, 1, 1)) > 0) break;
        flip = true;
      }
    }
  }
};

const CaseTable& Table() {
  static const CaseTable table;
  return table;
}

}  // namespace

void MarchingCubesOptions::Check() const {
  core::Require(std::isfinite(min_weight) && min_weight >= 0.0, "marching cubes: min_weight",
                "must be >= 0, got " + std::to_string(min_weight));
}

StreamingMarchingCubes::StreamingMarchingCubes(const fusion::VolumeGrid& grid,
                                               const MarchingCubesOptions& options)
    : grid_(grid), options_(options) {
  grid_.Check();
  options_.Check();
  const size_t n = size_t(grid_.PlaneVoxels());
  for (int s = 0; s < 2; ++s) {
    distance_[s].assign(n, 0.0f);
    class_[s].assign(n, 0);
    x_edge_[s].assign(n, -1);
    y_edge_[s].assign(n, -1);
  }
  z_edge_.assign(n, -1);
  active_.assign(size_t(grid_.nx), 0);
}

void StreamingMarchingCubes::AddSlab(const fusion::Slab& slab) {
  core::Require(slab.nx == grid_.nx && slab.ny == grid_.ny, "slab",
                "plane size " + std::to_string(slab.nx) + "x" + std::to_string(slab.ny) +
                    " does not match the volume's " + std::to_string(grid_.nx) + "x" +
                    std::to_string(grid_.ny));
  grid_.CheckSlab(slab.k0, slab.k1, "slab");
  for (int k = slab.k0; k < slab.k1; ++k) AddPlane(k, slab.PlaneDistance(k), slab.PlaneWeight(k));
}

int StreamingMarchingCubes::VertexOnEdge(int slot, int axis, int i, int j) {
  const int nx = grid_.nx;
  const size_t idx = size_t(j) * nx + i;
  int* entry = axis == 0 ? &x_edge_[slot][idx] : axis == 1 ? &y_edge_[slot][idx] : &z_edge_[idx];
  if (*entry >= 0) return *entry;
  // Ends a (lower index) and b of the edge.
  const size_t ia = idx;
  const size_t ib = axis == 0 ? idx + 1 : axis == 1 ? idx + nx : idx;
  const float va = axis == 2 ? distance_[0][ia] : distance_[slot][ia];
  const float vb = axis == 2 ? distance_[1][ib] : distance_[slot][ib];
  // Kept kEdgeMargin of the edge away from its ends: a corner at distance 0 (or a
  // crossing rounding onto it) would otherwise put the vertices of all its edges on one
  // point, and their triangles would have no area -- which mesh tools that divide by a
  // triangle's area (normals, closest-point queries) cannot take.
  const double t =
      std::clamp(double(va) / (double(va) - double(vb)), kEdgeMargin, 1.0 - kEdgeMargin);
  const int k = next_plane_ - 2 + (axis == 2 ? 0 : slot);
  Eigen::Vector3d p = grid_.VoxelCentreMm(i, j, k);
  p[axis] += t * grid_.voxel_size_mm;
  *entry = static_cast<int>(mesh_.vertices.size());
  set_[axis == 2 ? 4 : 2 * axis + slot].push_back(idx);
  mesh_.vertices.push_back(p.cast<float>());
  return *entry;
}

namespace {

constexpr uint8_t kObserved = 1, kInside = 2;  // StreamingMarchingCubes::class_ bits
// The byte loops below run in blocks of this many: a fixed trip count is what lets the
// compiler vectorize them at -O2 (its cheap cost model takes no loop of unknown length).
constexpr size_t kByteBlock = 64;

// A NaN weight is unobserved and a NaN distance outside, as in a per-corner test.
inline uint8_t VoxelClass(float weight, float distance_mm, float min_weight) {
  return uint8_t((weight > min_weight ? kObserved : 0) | (distance_mm < 0.0f ? kInside : 0));
}

// Marks which of n cells are polygonized (1) or not (0): cell i has the corners i and
// i + 1 of rows a0, b0 (plane k-1) and a1, b1 (plane k); polygonized when every corner is
// observed, one inside and one not.
inline void MarkCells(const uint8_t* __restrict a0, const uint8_t* __restrict b0,
                      const uint8_t* __restrict a1, const uint8_t* __restrict b1, size_t n,
                      uint8_t* __restrict active) {
  for (size_t i = 0; i < n; ++i) {
    const uint8_t all =
        a0[i] & a0[i + 1] & b0[i] & b0[i + 1] & a1[i] & a1[i + 1] & b1[i] & b1[i + 1];
    const uint8_t any =
        a0[i] | a0[i + 1] | b0[i] | b0[i + 1] | a1[i] | a1[i + 1] | b1[i] | b1[i + 1];
    active[i] = uint8_t(all & kObserved & (any >> 1) & ~(all >> 1));
  }
}

// The classes of n voxels.
inline void ClassifyVoxels(const float* __restrict weight, const float* __restrict distance_mm,
                           size_t n, float min_weight, uint8_t* __restrict out) {
  for (size_t v = 0; v < n; ++v) out[v] = VoxelClass(weight[v], distance_mm[v], min_weight);
}

}  // namespace

void StreamingMarchingCubes::MarkActiveCells(int j) {
  const size_t nx = size_t(grid_.nx), row = size_t(j) * nx;
  const uint8_t* a0 = class_[0].data() + row;  // plane k-1, rows j and j + 1
  const uint8_t* a1 = class_[1].data() + row;  // plane k
  size_t i = 0;
  // Whole blocks (a fixed count: vectorized), then the rest.
  for (; i + kByteBlock < nx; i += kByteBlock) {
    MarkCells(a0 + i, a0 + nx + i, a1 + i, a1 + nx + i, kByteBlock, active_.data() + i);
  }
  MarkCells(a0 + i, a0 + nx + i, a1 + i, a1 + nx + i, nx - 1 - i, active_.data() + i);
}

void StreamingMarchingCubes::AddPlane(int k, const float* distance_mm, const float* weight) {
  core::Require(k == next_plane_, "slab",
                "plane " + std::to_string(k) + " arrived but plane " + std::to_string(next_plane_) +
                    " was expected next");
  core::Require(k < grid_.nz, "slab", "plane " + std::to_string(k) + " is outside the volume");
  const size_t n = size_t(grid_.PlaneVoxels());
  std::swap(distance_[0], distance_[1]);
  std::swap(class_[0], class_[1]);
  std::swap(x_edge_[0], x_edge_[1]);
  std::swap(y_edge_[0], y_edge_[1]);
  std::swap(set_[0], set_[1]);
  std::swap(set_[2], set_[3]);
  std::copy(distance_mm, distance_mm + n, distance_[1].begin());
  const float min_w = static_cast<float>(options_.min_weight);
  size_t v = 0;
  for (; v + kByteBlock <= n; v += kByteBlock) {
    ClassifyVoxels(weight + v, distance_mm + v, kByteBlock, min_w, class_[1].data() + v);
  }
  ClassifyVoxels(weight + v, distance_mm + v, n - v, min_w, class_[1].data() + v);
  // Slot 1's maps held plane k-2's vertices, z's the previous pair's: only the entries
  // set are reset (a surface crosses a few percent of a plane's edges).
  for (int m : {1, 3, 4}) {
    std::vector<int>& map = m == 1 ? x_edge_[1] : m == 3 ? y_edge_[1] : z_edge_;
    for (size_t idx : set_[m]) map[idx] = -1;
    set_[m].clear();
  }
  ++next_plane_;
  if (k == 0) return;

  const int nx = grid_.nx, ny = grid_.ny;
  const CaseTable& table = Table();
  for (int j = 0; j + 1 < ny; ++j) {
    MarkActiveCells(j);
    const uint8_t* active = active_.data();
    for (int i = 0; i + 1 < nx; ++i) {
      if (!active[i]) {
        // Most of a row is empty or unobserved space: 8 cells a step past it.
        uint64_t eight;
        while (i + 9 < nx && (std::memcpy(&eight, active + i, 8), eight == 0)) i += 8;
        if (!active[i]) continue;
      }
      int code = 0;
      for (int c = 0; c < 8; ++c) {
        const int s = (c >> 2) & 1;
        const size_t idx = size_t(j + ((c >> 1) & 1)) * nx + i + (c & 1);
        if (class_[s][idx] & kInside) code |= 1 << c;
      }
      for (const auto& tri : table.triangles[code]) {
        Eigen::Vector3i face;
        for (int m = 0; m < 3; ++m) {
          const int a = kEdgeCorners[tri[m]][0];  // lower corner of the edge
          const int b = kEdgeCorners[tri[m]][1];
          const int axis = (a ^ b) == 1 ? 0 : (a ^ b) == 2 ? 1 : 2;
          const int ci = i + (a & 1), cj = j + ((a >> 1) & 1), slot = (a >> 2) & 1;
          face[m] = VertexOnEdge(slot, axis, ci, cj);
        }
        mesh_.faces.push_back(face);
      }
    }
  }
}

io::Mesh StreamingMarchingCubes::Finish() { return std::move(mesh_); }

io::Mesh MarchingCubes(const fusion::VolumeGrid& grid, const std::vector<float>& distance_mm,
                       const std::vector<float>& weight, const MarchingCubesOptions& options) {
  grid.Check();
  const size_t n = size_t(grid.PlaneVoxels());
  DOME_CHECK(distance_mm.size() == n * grid.nz && weight.size() == n * grid.nz,
             "volume arrays must hold nx * ny * nz values");
  StreamingMarchingCubes mc(grid, options);
  for (int k = 0; k < grid.nz; ++k)
    mc.AddPlane(k, distance_mm.data() + k * n, weight.data() + k * n);
  return mc.Finish();
}

MeshTopology AnalyzeTopology(const io::Mesh& mesh) {
  // Per undirected edge: count of uses and the sum of directions (+1 a<b, -1 a>b).
  std::unordered_map<uint64_t, std::pair<int, int>> edges;
  edges.reserve(mesh.faces.size() * 2);
  for (const auto& f : mesh.faces) {
    for (int m = 0; m < 3; ++m) {
      const uint32_t a = f[m], b = f[(m + 1) % 3];
      const uint64_t key = (uint64_t(std::min(a, b)) << 32) | std::max(a, b);
      auto& e = edges[key];
      e.first += 1;
      e.second += a < b ? 1 : -1;
    }
  }
  MeshTopology t;
  t.edges = int64_t(edges.size());
  for (const auto& [key, e] : edges) {
    if (e.first == 1) ++t.boundary_edges;
    if (e.first > 2) ++t.non_manifold_edges;
    if (e.first == 2 && e.second != 0) ++t.inconsistent_edges;
  }
  return t;
}

double SurfaceAreaMm2(const io::Mesh& mesh) {
  double area = 0.0;
  for (const auto& f : mesh.faces) {
    const Eigen::Vector3d a = mesh.vertices[f[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[f[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[f[2]].cast<double>();
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  return area;
}

}  // namespace dome::mesh
