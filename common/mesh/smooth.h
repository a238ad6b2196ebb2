// Taubin's lambda|mu mesh smoothing (Taubin 1995, "A signal processing approach to fair
// surface design"): each iteration moves every vertex by lambda times the umbrella
// Laplacian (the mean of its edge neighbours minus itself), then by mu (< -lambda) times
// it again. The first step is a Laplacian smoothing, the second an inflation that
// undoes its shrinkage: a low-pass filter with pass-band frequency
// k_PB = 1/lambda + 1/mu (0.113 with the defaults), which removes the high-frequency
// noise of a fused surface (the per-camera depth noise seen in the zero crossing)
// without shrinking it as repeated Laplacian smoothing would.
//
// Every vertex moves, open-border ones included (their neighbours are on one side; mu
// compensates as in the interior). Faces, normals and colours are left as they are
// (normals, if any, are not recomputed). The result is a deterministic function of the
// mesh: vertex order and the order of each vertex's neighbours fix the sums.
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
