// Marching cubes (Lorensen & Cline 1987; seed §4.5) on the zero crossing of the fused
// signed distance (fusion/volume.h), streamed plane by plane.
//
// Slabs arrive in plane order; only two planes of values and their edge-vertex index
// maps are held, so memory is bounded by a plane, not the volume. A vertex lies on a
// voxel edge whose two ends have opposite signs (inside = distance < 0), at the linear
// zero crossing between the two voxel centres (world frame, mm), kept a thousandth of
// the edge away from either end so that no triangle is degenerate; it is created once
// and shared by every cell around that edge, so the mesh is watertight wherever the
// surface is closed and observed -- across slab seams too: the output (vertex order
// included) does not depend on how the planes were cut into slabs.
//
// A cell is polygonized only when all 8 corners have weight > min_weight (observed;
// Curless & Levoy). The case table is built from the cube's faces: on every face the
// contour separates the inside corners (an ambiguous face keeps its two inside
// corners apart), which both cells sharing that face agree on -- no cracks. Triangles
// are counter-clockwise seen from outside (normals point to positive distance, free
// space), as io::Mesh expects.
#pragma once

#include <cstdint>
#include <vector>

#include "fusion/volume.h"
#include "io/mesh.h"

namespace dome::mesh {

struct MarchingCubesOptions {
  // Cells with a corner of weight <= min_weight are skipped (weight: sum of fusion
  // weights, unitless).
  double min_weight = 0.0;
  // Check() throws core::InputError naming the first option out of range.
  void Check() const;
};

class StreamingMarchingCubes {
 public:
  explicit StreamingMarchingCubes(const fusion::VolumeGrid& grid,
                                  const MarchingCubesOptions& options = {});

  // Adds the planes of `slab`, which must start at the next plane expected (0 first)
  // and match the grid's plane size; core::InputError otherwise.
  void AddSlab(const fusion::Slab& slab);
  // Adds plane `k` (nx * ny values, row-major); k must be the next plane.
  void AddPlane(int k, const float* distance_mm, const float* weight);
  int next_plane() const { return next_plane_; }

  // The mesh so far (all planes added: the whole surface). Moves the mesh out.
  io::Mesh Finish();

 private:
  int VertexOnEdge(int plane_slot, int axis, int i, int j);
  // Marks in active_ the cells (i, j), i < nx - 1, of the plane pair that are
  // polygonized: all 8 corners observed and not all on one side of the surface.
  void MarkActiveCells(int j);

  fusion::VolumeGrid grid_;
  MarchingCubesOptions options_;
  int next_plane_ = 0;
  // Slot 0: plane k-1, slot 1: plane k.
  std::vector<float> distance_[2];
  // Per voxel of the plane: observed (weight > min_weight) | inside (distance < 0) bits.
  std::vector<uint8_t> class_[2];
  std::vector<uint8_t> active_;  // per cell of the row being polygonized: 1 = polygonize
  std::vector<int> x_edge_[2];   // vertex on edge (i,j)-(i+1,j) of the plane, -1 none yet
  std::vector<int> y_edge_[2];   // vertex on edge (i,j)-(i,j+1)
  std::vector<int> z_edge_;      // vertex on edge (i,j,k-1)-(i,j,k)
  // The entries of each edge map set since it was last reset (x of slot 0, of slot 1, y
  // of slot 0, of slot 1, then z): a plane resets only these, not the whole map.
  std::vector<size_t> set_[5];
  io::Mesh mesh_;
};

// Whole-volume convenience: the mesh of the zero crossing of `distance_mm`/`weight`
// (plane-major, nx*ny*nz values each).
io::Mesh MarchingCubes(const fusion::VolumeGrid& grid, const std::vector<float>& distance_mm,
                       const std::vector<float>& weight, const MarchingCubesOptions& options = {});

// Mesh checks used by tests and reports.
struct MeshTopology {
  int64_t edges = 0;
  int64_t boundary_edges = 0;      // edges with one triangle
  int64_t non_manifold_edges = 0;  // edges with more than two triangles
  int64_t inconsistent_edges = 0;  // edges two triangles traverse in the same direction
};
MeshTopology AnalyzeTopology(const io::Mesh& mesh);
double SurfaceAreaMm2(const io::Mesh& mesh);

}  // namespace dome::mesh
