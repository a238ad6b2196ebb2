// Quadric-error mesh decimation (Garland & Heckbert 1997; seed §4.5 "decimated ...
// with little loss in structural accuracy"), by meshoptimizer's topology-preserving
// edge-collapse simplifier (Debian libmeshoptimizer-dev): collapses never change the
// topology (no holes opened, no separate parts welded), open borders are kept.
// meshoptimizer keeps the surviving vertices where they were (on the input surface,
// so the coarse triangles cut chords through curved parts); a second pass places each
// surviving interior vertex at the quadric optimum of the input faces around it
// (the input vertices nearest to it in edge hops), moving it only along the
// directions those faces determine.
// Units: the mesh's (mm for dome's meshes).
#pragma once

#include <cstdint>

#include "io/mesh.h"

namespace dome::mesh {

struct DecimationOptions {
  // Target triangle count; 0: use target_ratio.
  int64_t target_triangles = 0;
  // Target as a fraction of the input triangles, in (0, 1].
  double target_ratio = 0.1;
  // Stop before a collapse would move the surface more than this, in mm; 0 = no bound.
  double max_error_mm = 0.0;
  // Keep vertices on open borders in place (a slab or volume edge, unobserved parts).
  bool lock_border = true;
  // Place surviving interior vertices at their quadric optimum (above).
  bool relocate_vertices = true;

  // Throws core::InputError naming the first option out of range.
  void Check() const;
};

struct DecimationSummary {
  int64_t triangles_in = 0;
  int64_t triangles_out = 0;
  double error_mm = 0.0;  // the simplifier's estimate of the largest deviation, mm
  double seconds = 0.0;
};

// The simplified mesh, vertices compacted (first-use order); colours and normals are
// carried along for the vertices that remain.
io::Mesh Decimate(const io::Mesh& mesh, const DecimationOptions& options,
                  DecimationSummary* summary = nullptr);

}  // namespace dome::mesh
