// Accuracy and completeness of a reconstruction (mesh or point cloud) against a
// reference, in the manner of the Middlebury multi-view benchmark (Seitz, Curless,
// Diebel, Scharstein & Szeliski, CVPR 2006), computed exactly as the project's
// yardstick ../tools/eval_cloud.py does so the two agree (see tests/eval).
//
// Everything is converted to millimetres first (recon_unit_mm, reference_unit_mm).
//
//  * Evaluation box: the reference's axis-aligned bounding box (of its vertices),
//    extent scaled by (1 + box_margin) about its centre. Reconstruction points outside
//    it are counted (n_outside_box) but do not enter accuracy: the reference does not
//    model the background, table, or the rest of the rig.
//  * Reconstruction points: a cloud's vertices; for a mesh (any faces), a uniform
//    sample of its surface with max(min_mesh_samples, area * mesh_sample_density)
//    points (deterministic for a given seed).
//  * Accuracy: for each reconstruction point inside the box, the distance to the
//    nearest reference point (median, mean, 90th percentile) and precision@t = the
//    fraction of them within t.
//  * Completeness: for each reference point, the distance to the whole
//    reconstruction (box or not): nearest point of a cloud; for a mesh, the exact
//    point-to-triangle distance (or, with completeness_from_samples, the nearest
//    point of a denser surface sample, like eval_cloud.py --sampled);
//    completeness@t = the fraction within t. fscore@t = 2 p r / (p + r).
//  * A reference with faces is used through its vertices by default (what
//    eval_cloud.py does: it reads the reference as a point cloud). With
//    ReferenceMeshUse::kSurface, its surface is sampled uniformly
//    (reference_sample_density_per_mm2) for completeness and accuracy is measured
//    to its triangles exactly, which removes the floor that point spacing puts under
//    point-to-point accuracy (the report gives ref_spacing_median_mm for context).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "io/mesh.h"

namespace dome::eval {

enum class ReferenceMeshUse {
  kVertices,  // reference points = its vertices (eval_cloud.py's behaviour)
  kSurface,   // reference points = a surface sample; accuracy to its triangles
};

struct CloudEvalOptions {
  // Distance thresholds for precision / completeness / F-score, in mm.
  std::vector<double> thresholds_mm = {0.5, 1.0, 2.0};
  // Enlargement of the reference bounding box, as a fraction of its extent (0.1: the
  // box is 10% longer along each axis, 5% on each side).
  double box_margin = 0.1;
  // Millimetres per coordinate unit of the reconstruction (1 for dome's own output;
  // 1000 for a file in metres). eval_cloud.py: --recon-unit.
  double recon_unit_mm = 1.0;
  // Millimetres per coordinate unit of the reference (1000 for the Robovision
  // reference.ply files, which are in metres). eval_cloud.py: --unit.
  double reference_unit_mm = 1.0;
  // Surface samples per mm^2 on a reconstruction mesh for accuracy
  // (eval_cloud.py --mesh-density).
  double mesh_sample_density_per_mm2 = 20.0;
  // At least this many samples on a reconstruction mesh (eval_cloud.py uses 1000).
  int64_t min_mesh_samples = 1000;
  // At most this many samples on any mesh (memory guard: 20 / mm^2 over a whole
  // person would be tens of millions of points; lower the densities at dome scale).
  int64_t max_mesh_samples = 50'000'000;
  // Completeness of a mesh reconstruction from a dense surface sample instead of
  // exact point-to-triangle distances (eval_cloud.py --sampled).
  bool completeness_from_samples = false;
  // Samples per mm^2 for completeness_from_samples (eval_cloud.py --comp-density).
  double completeness_sample_density_per_mm2 = 400.0;
  // How a reference that has faces is used (see the file comment).
  ReferenceMeshUse reference_mesh_use = ReferenceMeshUse::kVertices;
  // Samples per mm^2 on a reference mesh with ReferenceMeshUse::kSurface.
  double reference_sample_density_per_mm2 = 20.0;
  // Seed of every surface sample.
  uint64_t seed = 0;
  // Threads for the distance queries; <= 0: all hardware threads.
  int num_threads = 0;

  // Throws core::InputError naming the first option out of range.
  void Check() const;
};

struct ThresholdScores {
  double threshold_mm = 0.0;
  double precision = 0.0;     // fraction of in-box reconstruction points within threshold
  double completeness = 0.0;  // fraction of reference points within threshold
  double fscore = 0.0;        // harmonic mean of the two, 0 when both are 0
};

struct CloudEvalReport {
  std::string recon;              // file name, when evaluated from files
  std::string reference;          // file name, when evaluated from files
  std::string kind;               // "mesh" or "cloud": what the reconstruction is
  int64_t n_recon_pts = 0;        // reconstruction points (mesh: surface samples)
  int64_t n_in_box = 0;           // of those, inside the evaluation box
  int64_t n_outside_box = 0;      // of those, outside it
  double frac_outside_box = 0.0;  // n_outside_box / n_recon_pts (NaN when no points)
  double box_margin = 0.0;
  Eigen::Vector3d box_min_mm = Eigen::Vector3d::Zero();  // evaluation box, mm
  Eigen::Vector3d box_max_mm = Eigen::Vector3d::Zero();
  int64_t n_ref_pts = 0;               // reference points used for completeness
  int64_t n_triangles = 0;             // reconstruction triangles (0 for a cloud)
  double ref_spacing_median_mm = 0.0;  // median nearest-other-point distance in the reference
  // Accuracy over in-box points, mm; NaN when no point is inside the box.
  double acc_median_mm = 0.0;
  double acc_mean_mm = 0.0;
  double acc_p90_mm = 0.0;
  // Median distance of reference points to the reconstruction, mm (inf when empty).
  double comp_median_mm = 0.0;
  // "nearest_point", "point_to_triangle" or "surface_sample".
  std::string completeness_method;
  std::vector<ThresholdScores> scores;  // one per threshold, in the options' order
  double seconds = 0.0;                 // wall time of the evaluation (not in the JSON)

  bool has_accuracy() const { return n_in_box > 0; }
  // A few human-readable lines for logs.
  std::string BriefReport() const;
};

// Evaluates `recon` against `reference` (coordinates in their own units, scaled by the
// options). Throws core::InputError when the reference has no points or a mesh is
// inconsistent (face index out of range), naming which input.
CloudEvalReport EvaluateReconstruction(const io::Mesh& recon, const io::Mesh& reference,
                                       const CloudEvalOptions& options);

// Reads both PLY files (io::ReadPly) and evaluates them; errors name the files.
CloudEvalReport EvaluateReconstructionFiles(const std::filesystem::path& recon,
                                            const std::filesystem::path& reference,
                                            const CloudEvalOptions& options);

// One-line JSON with eval_cloud.py's keys: recon, reference, kind, n_recon_pts,
// n_in_box, n_outside_box, frac_outside_box, box_margin, n_ref_pts, n_triangles (mesh
// only), ref_spacing_median_mm, acc_median_mm, acc_mean_mm, acc_p90_mm,
// comp_median_mm, precision@<t>mm, completeness@<t>mm, fscore@<t>mm (t printed with
// '%g'); plus box_min_mm, box_max_mm and comp_method. Unlike the script, which stops
// after ref_spacing_median_mm when no point is inside the box, the accuracy keys are
// then null and completeness is still reported.
std::string ToJson(const CloudEvalReport& report);

}  // namespace dome::eval
