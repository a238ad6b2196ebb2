// Taubin's lambda|mu mesh smoothing (Taubin 1995, "A signal processing approach to fair
// surface design"): each iteration moves every vertex by lambda times the umbrella
// Laplacian (the mean of its edge neighbours minus itself), then by mu (< -lambda) times
// it again. The first step is a Laplacian smoothing, the second an inflation that
// undoes its shrinkage: a low-pass filter with pass-band frequency
// k_PB = 1/lambda + 1/mu (0.113 with the defaults): high-frequency noise goes, a
// closed surface keeps its size (repeated Laplacian smoothing would shrink it).
//
// Every vertex moves, open-border ones included. A border vertex's neighbours are all on
// one side, so borders are pulled in along the surface: on fused real surfaces (holes,
// small fragments) most of the accuracy gained is this pull on the ragged borders, where
// the depth is worst, at a small cost in completeness (README, Robovision). Faces,
// normals and colours are left as they are (normals, if any, are not recomputed). The
// result is a deterministic function of the mesh (vertex order fixes the sums).
//
// Units: the mesh's (mm for dome's meshes); lambda and mu are dimensionless.
#pragma once

#include "io/mesh.h"

namespace dome::mesh {

struct SmoothOptions {
  int iterations = 0;     // lambda|mu pairs; 0: the mesh is left unchanged
  double lambda = 0.5;    // shrinking step, (0, 1]
  double mu = -0.53;      // inflating step, < -lambda and >= -1

  // Throws core::InputError naming "smooth_iterations", "smooth_lambda" or "smooth_mu".
  void Check() const;
};

// Smooths `mesh` in place. Face indices must be valid (io::CheckMesh's rule).
void SmoothTaubin(const SmoothOptions& options, io::Mesh* mesh);

}  // namespace dome::mesh
