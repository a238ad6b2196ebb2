// Taubin's lambda|mu mesh smoothing (Taubin 1995, "A signal processing approach to fair
// surface design"): each iteration moves every vertex by lambda times the umbrella
// Laplacian (the mean of its edge neighbours minus itself), then by mu (< -lambda) times
// it again. The first step is a Laplacian smoothing, the second an inflation that
// undoes its shrinkage: a low-pass filter with pass-band frequency
// k_PB = 1/lambda + 1/mu (0.113 with the defaults): high-frequency noise goes, a
// closed surface keeps its size (repeated Laplacian smoothing would shrink it).
//
// Smoothing also draws the corners of a tiny triangle together (its size shrinks about
// 0.77 times an iteration with the defaults), until in float they meet and the triangle
// has no area, which mesh tools that divide by a triangle's area (normals,
// closest-point queries) cannot take. So edges shorter than a thousandth of the mean
// edge length are welded afterwards (WeldShortEdges).
//
// Every vertex moves, open-border ones included. A border vertex's neighbours are all on
// one side, so borders are pulled in along the surface: on fused real surfaces (holes,
// small fragments) most of the accuracy gained is this pull on the ragged borders, where
// the depth is worst, at a small cost in completeness (README, Robovision). Normals and
// colours are left as they are (normals, if any, are not recomputed); faces and vertices
// change only by the welding. The result is a deterministic function of the mesh
// (vertex order fixes the sums), the same on any number of threads.
//
// Units: the mesh's (mm for dome's meshes); lambda and mu are dimensionless.
#pragma once

#include "io/mesh.h"

namespace dome::mesh {

struct SmoothOptions {
  int iterations = 0;   // lambda|mu pairs; 0: the mesh is left unchanged
  double lambda = 0.5;  // shrinking step, (0, 1]
  double mu = -0.53;    // inflating step, < -lambda and >= -1
  // Threads the vertices are split over; 0: every hardware thread. The result is the
  // same bits for any count.
  int num_threads = 0;

  // Throws core::InputError naming "smooth_iterations", "smooth_lambda" or "smooth_mu".
  void Check() const;
};

// Smooths `mesh` in place, then welds its short edges (above). Face indices must be
// valid (io::CheckMesh's rule).
void SmoothTaubin(const SmoothOptions& options, io::Mesh* mesh);

// Merges the two ends of every edge shorter than `min_length` (mesh units) into one
// vertex: the least index of each merged set keeps its position and attributes. Faces
// left with a repeated vertex are dropped, then the vertices the welding left without a
// face, and the rest are renumbered in order. Returns the number of faces dropped.
int WeldShortEdges(double min_length, io::Mesh* mesh);

}  // namespace dome::mesh
