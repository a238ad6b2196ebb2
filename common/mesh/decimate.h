// Quadric-error mesh decimation (Garland & Heckbert 1997; seed §4.5 "decimated ...
// with little loss in structural accuracy").
//
// Default method, kEdgeCollapse: greedy edge collapses in order of quadric error
// (area-weighted squared distances to the planes of the input faces merged into a
// vertex), each vertex placed at the quadric optimum (minimum-norm solution from the
// edge midpoint where the planes leave a direction undetermined, so flat regions
// collapse with zero error). A collapse is refused when it would break the 2-manifold
// (link condition, open borders included), flip or nearly degenerate a triangle, or
// move a locked vertex. Colours, alphas and normals are interpolated along the edge.
// Before decimating, connected components smaller than a triangle count or bounding-box
// diagonal can be dropped (the small floating parts stereo noise leaves in a fused
// mesh); the target counts against the input triangles, so dropped parts count towards
// the reduction. During decimation a whole component can also be deleted when that is
// cheaper than the next collapse (component_deletion_factor): the budget then goes to
// the surface instead of to thousands of floaters each held at its last few triangles.
// A collapse's cost also counts how far its new faces stray from the faces they
// replace (deviation_weight), which the quadric does not see.
//
// kMeshoptimizer: meshoptimizer's topology-preserving simplifier (Debian
// libmeshoptimizer-dev), surviving vertices optionally moved to the quadric optimum of
// the input faces around them.
//
// Units: the mesh's (mm for dome's meshes).
#pragma once

#include <cstdint>

#include "io/mesh.h"

namespace dome::mesh {

enum class DecimationMethod { kEdgeCollapse, kMeshoptimizer };

struct DecimationOptions {
  // Target triangle count; 0: use target_ratio.
  int64_t target_triangles = 0;
  // Target as a fraction of the input triangles, in (0, 1].
  double target_ratio = 0.1;
  // Never make a collapse whose estimated error (root-mean-square distance to the planes
  // of the input faces merged into the vertex) exceeds this, in mm; 0 = no bound.
  double max_error_mm = 0.0;
  // Keep vertices on open borders in place (a slab or volume edge, unobserved parts).
  // When false, borders may be simplified but are held by penalty planes through each
  // border edge, perpendicular to its face, weighted border_weight times the edge
  // length squared (kEdgeCollapse only). Off by default: a stereo mesh has so much
  // border (holes, floaters) that locking it keeps the target out of reach. A light
  // weight lets ragged stereo borders straighten, which frees triangles for the surface.
  bool lock_border = false;
  double border_weight = 0.01;  // dimensionless, >= 0
  // Drop connected components (faces joined by shared vertices) with fewer triangles than
  // this before decimating; 0 = keep all. The default drops the lone triangles, pairs
  // and triples that stereo noise leaves in a fused mesh (no real part is that small).
  int64_t min_component_triangles = 4;
  // Drop connected components whose bounding-box diagonal is below this, mm; 0 = keep.
  double min_component_diagonal_mm = 0.0;
  // Specks, dropped before decimating: connected components whose area is below
  // speck_area_fraction of the largest component's AND whose bounding-box diagonal is
  // below speck_diagonal_mm. Both must hold, so a part large in extent (a bat, a pole)
  // or in area stays however thin it is. 0 (either) = keep all. Dimensionless in [0, 1),
  // and mm, >= 0.
  double speck_area_fraction = 0.0;
  double speck_diagonal_mm = 0.0;
  // ... and no vertex of it within speck_gap_mm of a part that is not small (over either
  // bound): a fragment beside the surface (a bat's barrel where stereo broke it off) is
  // detail, a fragment in the air is a wrong match. mm, >= 0; 0 = small parts go
  // wherever they are.
  double speck_gap_mm = 0.0;
  // kEdgeCollapse: delete a whole connected component, in the same cost order as the
  // collapses, when that is cheaper than the next collapse. Its cost is that of moving
  // all its area by an error estimate of this factor times the geometric mean of its
  // bounding-box diagonal and its distance to the largest component (at least the
  // diagonal), so small floaters near the surface go first and the budget goes to the
  // surface instead of to thousands of floaters each held at its last few triangles.
  // The component with the largest area is never deleted, and a deletion that would go
  // below the target or above max_error_mm is skipped. Dimensionless, >= 0; 0 = never.
  // (0.035 with the deviation term below, which makes collapses dearer: at 0.025 the
  // deletions took so much of a stereo mesh at 10% that the original's mean distance
  // to the result was 11.8 mm against 8.4.)
  double component_deletion_factor = 0.035;
  // kEdgeCollapse: add to a collapse's cost this weight times the merged area (the sum
  // of its quadric's plane weights, mm^2) times the square of its deviation: the
  // largest distance of points of the new faces (centroids, midpoints of the edges
  // from the new vertex) to the faces around the edge before, mm. A face spanning a gap
  // in a ragged border or cutting across a fold then costs what moving the whole area
  // by that distance would; the quadric alone measures the vertex, not the faces
  // around it, and lets such faces through at a low cost. This bounds the worst-case
  // distance to the original surface (at 10% of a fused mesh's triangles: 2.9 mm
  // against 7.7 mm without, the mean 4% lower too) for about twice the time.
  // Dimensionless, >= 0; 0 = quadric only.
  double deviation_weight = 1.0;
  // kEdgeCollapse: the deviation term counts only once a run of collapses (a region's,
  // or the pass over the joined regions) is within this factor of its target faces;
  // before that the queue is ordered by the quadric alone. The early collapses are
  // short edges in the flattest parts, which rarely stray, yet measuring them took
  // about half the time. At 2 against 0 (`bench/fusion/decimation_ab.py --quality`,
  // 10 % targets, four surfaces: a Robovision scene, the paper take without masks,
  // templeSparseRing, a Panoptic instant): 0.66-0.83x the wall time, the mean distance
  // to the input from 2.5 % lower to 1.0 % higher. Dimensionless, 0 (the term from
  // the first collapse) or >= 1.
  double deviation_from_factor = 2.0;
  // kEdgeCollapse: first simplify with meshoptimizer to this times the target (it is
  // far faster and moves no vertex), each kept vertex starting with the quadrics of the
  // input vertices nearest to it, so the collapses that follow still measure against
  // the input surface; 0 = edge collapse from the input. Dimensionless, 0 or > 1.
  double prepass_factor = 0.0;
  // kEdgeCollapse: decimate a large mesh in regions, one per faces_per_region faces
  // (the largest power of two, at most 64, that leaves each region this many), in
  // parallel, then the joined regions (see Decimate); 0 = one region. The count comes
  // from the face count only, so the output is the same for any num_threads. 10000: a
  // region's records then stay nearer the core's caches, and the second round of
  // regions (Decimate) collapses in parallel most of what the first round's seams kept.
  // Against 20000 (`bench/fusion/decimation_ab.py`, 5 pairs, 2 threads, AVX-512): a
  // Panoptic instant's 1.34 M faces (64 regions against 32) 0.89x the wall, Robovision
  // 17_43_02's 358 k (16 against 8) 0.96x, the paper instant's 127 k 0.97x,
  // templeSparseRing's 470 k 1.05x (0.98x the CPU), every distance to the input within
  // 0.4 % or closer. (At 20000, before the second round: 8 regions of the Robovision
  // surface took 0.75x the CPU of 4, and templeSparseRing 1.2x the wall in 32 as in 16.)
  // Faces, >= 0.
  int64_t faces_per_region = 10000;
  // Threads the regions run on; <= 0: the hardware's. Does not change the output.
  int num_threads = 0;
  DecimationMethod method = DecimationMethod::kEdgeCollapse;
  // kMeshoptimizer only: place surviving interior vertices at their quadric optimum.
  bool relocate_vertices = true;

  // Throws core::InputError naming the first option out of range.
  void Check() const;
};

struct DecimationSummary {
  int64_t triangles_in = 0;
  int64_t triangles_out = 0;
  int64_t components_removed = 0;  // dropped by the component filters
  int64_t triangles_removed = 0;   // their triangles
  int64_t specks_removed = 0;      // dropped by the speck rule
  int64_t speck_triangles = 0;     // their triangles
  int64_t components_deleted = 0;  // deleted whole during decimation
  int64_t triangles_deleted = 0;   // their triangles left at the time
  double error_mm = 0.0;           // largest error estimate of a collapse made, mm
  double seconds = 0.0;
};

// The simplified mesh, vertices compacted (first-use order). Stops at the target, at the
// error bound, or when no valid collapse is left.
//
// kEdgeCollapse on at least 2 x faces_per_region faces (after the component filters and
// the prepass, if any):
// the faces are cut into regions (slices of equal face counts along the longest axis of
// their bounding box; boxes, each face set halved along its longest side in turn, when
// the slices' seams would hold more than a quarter of the faces), each decimated on its own thread
// with the vertices it shares with another region locked, to the target's share of its faces away
// from those seams; the regions are then joined at the seam vertices. From 8 regions on, a second
// round of regions cut across the middle of the first round's (fewer of them) collapses what the
// first round's seams kept. Last, one pass over the whole mesh, seams free, brings it to
// the target. Quadrics stay those of the input surface throughout.
io::Mesh Decimate(const io::Mesh& mesh, const DecimationOptions& options,
                  DecimationSummary* summary = nullptr);

}  // namespace dome::mesh
