#include "eval/cloud_eval.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

#include "core/error.h"
#include "core/json.h"
#include "core/parallel_for.h"
#include "core/timer.h"
#include "eval/kd_tree.h"
#include "eval/statistics.h"
#include "eval/surface_sampling.h"
#include "eval/triangle_bvh.h"
#include "io/ply.h"

namespace dome::eval {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool PositiveFinite(double v) { return std::isfinite(v) && v > 0.0; }

std::vector<Eigen::Vector3f> Scaled(const std::vector<Eigen::Vector3f>& points, double unit_mm) {
  std::vector<Eigen::Vector3f> out(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    out[i] = (points[i].cast<double>() * unit_mm).cast<float>();
  }
  return out;
}

// Surface sample count for `area_mm2` at `density`, like eval_cloud.py:
// int(max(minimum, area * density)), capped.
int64_t SampleCount(double area_mm2, double density, const CloudEvalOptions& o) {
  const double n = std::max(static_cast<double>(o.min_mesh_samples), area_mm2 * density);
  return std::min(o.max_mesh_samples, static_cast<int64_t>(n));
}

std::vector<Eigen::Vector3f> SampleMesh(const std::vector<Eigen::Vector3f>& vertices_mm,
                                        const std::vector<Eigen::Vector3i>& faces, double density,
                                        uint64_t seed, const CloudEvalOptions& o,
                                        const std::string& which) {
  const double area = SurfaceArea(vertices_mm, faces);
  core::Require(area > 0.0, which, "mesh has faces but zero surface area");
  return SampleSurfaceUniformly(vertices_mm, faces, SampleCount(area, density, o), seed,
                                o.num_threads);
}

// Distance from each of `queries` to the nearest of the tree's points, in parallel.
std::vector<double> NearestDistances(const PointKdTree& tree,
                                     const std::vector<Eigen::Vector3f>& queries, int num_threads) {
  std::vector<double> d(queries.size());
  core::ParallelFor(0, static_cast<int64_t>(queries.size()), num_threads,
                    [&](int64_t b, int64_t e) {
                      for (int64_t i = b; i < e; ++i) {
                        d[i] = std::sqrt(static_cast<double>(tree.Nearest(queries[i]).distance_sq));
                      }
                    });
  return d;
}

std::vector<double> SurfaceDistances(const TriangleBvh& bvh,
                                     const std::vector<Eigen::Vector3f>& queries, int num_threads) {
  std::vector<double> d(queries.size());
  core::ParallelFor(0, static_cast<int64_t>(queries.size()), num_threads,
                    [&](int64_t b, int64_t e) {
                      for (int64_t i = b; i < e; ++i) {
                        d[i] = std::sqrt(bvh.Closest(queries[i].cast<double>()).distance_sq);
                      }
                    });
  return d;
}

}  // namespace

void CloudEvalOptions::Check() const {
  for (size_t i = 0; i < thresholds_mm.size(); ++i) {
    core::Require(PositiveFinite(thresholds_mm[i]), "thresholds_mm[" + std::to_string(i) + "]",
                  "must be a positive number of mm");
  }
  core::Require(std::isfinite(box_margin) && box_margin >= 0.0, "box_margin",
                "must be >= 0 (a fraction of the reference extent)");
  core::Require(PositiveFinite(recon_unit_mm), "recon_unit_mm", "must be positive (mm per unit)");
  core::Require(PositiveFinite(reference_unit_mm), "reference_unit_mm",
                "must be positive (mm per unit)");
  core::Require(PositiveFinite(mesh_sample_density_per_mm2), "mesh_sample_density_per_mm2",
                "must be positive");
  core::Require(min_mesh_samples >= 1, "min_mesh_samples", "must be >= 1");
  core::Require(max_mesh_samples >= min_mesh_samples, "max_mesh_samples",
                "must be >= min_mesh_samples");
  core::Require(PositiveFinite(completeness_sample_density_per_mm2),
                "completeness_sample_density_per_mm2", "must be positive");
  core::Require(PositiveFinite(reference_sample_density_per_mm2),
                "reference_sample_density_per_mm2", "must be positive");
}

namespace {

// `recon_name` / `reference_name` name the inputs in errors.
CloudEvalReport Evaluate(const io::Mesh& recon, const io::Mesh& reference,
                         const CloudEvalOptions& options, const std::string& recon_name,
                         const std::string& reference_name) {
  options.Check();
  const core::Stopwatch watch;
  const std::string recon_problem = recon.Inconsistency();
  core::Require(recon_problem.empty(), recon_name, recon_problem);
  const std::string reference_problem = reference.Inconsistency();
  core::Require(reference_problem.empty(), reference_name, reference_problem);
  core::Require(!reference.vertices.empty(), reference_name, "has no points");
  const int threads = options.num_threads;

  CloudEvalReport report;
  report.box_margin = options.box_margin;

  // Reference, in mm.
  const std::vector<Eigen::Vector3f> ref_vertices =
      Scaled(reference.vertices, options.reference_unit_mm);
  const bool ref_surface =
      reference.HasFaces() && options.reference_mesh_use == ReferenceMeshUse::kSurface;
  // Different seeds for the two samples so they are independent.
  const std::vector<Eigen::Vector3f> ref_points =
      ref_surface
          ? SampleMesh(ref_vertices, reference.faces, options.reference_sample_density_per_mm2,
                       options.seed + 1, options, reference_name)
          : ref_vertices;
  report.n_ref_pts = static_cast<int64_t>(ref_points.size());

  // Evaluation box about the reference vertices' bounding box, in double like the script.
  Eigen::Vector3d lo = reference.vertices[0].cast<double>(), hi = lo;
  for (const Eigen::Vector3f& v : reference.vertices) {
    lo = lo.cwiseMin(v.cast<double>());
    hi = hi.cwiseMax(v.cast<double>());
  }
  const Eigen::Vector3d centre = (lo + hi) / 2.0 * options.reference_unit_mm;
  const Eigen::Vector3d half =
      (hi - lo) / 2.0 * (1.0 + options.box_margin) * options.reference_unit_mm;
  report.box_min_mm = centre - half;
  report.box_max_mm = centre + half;

  // Reconstruction points, in mm.
  const std::vector<Eigen::Vector3f> recon_vertices = Scaled(recon.vertices, options.recon_unit_mm);
  const bool recon_mesh = recon.HasFaces();
  report.kind = recon_mesh ? "mesh" : "cloud";
  report.n_triangles = static_cast<int64_t>(recon.faces.size());
  const std::vector<Eigen::Vector3f> recon_points =
      recon_mesh ? SampleMesh(recon_vertices, recon.faces, options.mesh_sample_density_per_mm2,
                              options.seed, options, recon_name)
                 : recon_vertices;
  report.n_recon_pts = static_cast<int64_t>(recon_points.size());

  // A cloud's points are tested in double from the file's coordinates, so points on
  // the box boundary fall the same way as in the script.
  std::vector<Eigen::Vector3f> inside;
  inside.reserve(recon_points.size());
  for (size_t i = 0; i < recon_points.size(); ++i) {
    const Eigen::Vector3d p =
        recon_mesh ? Eigen::Vector3d(recon_points[i].cast<double>())
                   : Eigen::Vector3d(recon.vertices[i].cast<double>() * options.recon_unit_mm);
    if (((p - centre).cwiseAbs().array() <= half.array()).all()) {
      inside.push_back(recon_points[i]);
    }
  }
  report.n_in_box = static_cast<int64_t>(inside.size());
  report.n_outside_box = report.n_recon_pts - report.n_in_box;
  report.frac_outside_box = report.n_recon_pts > 0
                                ? static_cast<double>(report.n_outside_box) / report.n_recon_pts
                                : kNaN;

  // Accuracy: in-box reconstruction points to the reference.
  const PointKdTree ref_tree(ref_points);
  std::vector<double> d_acc;
  if (ref_surface) {
    const TriangleBvh ref_bvh(ref_vertices, reference.faces);
    d_acc = SurfaceDistances(ref_bvh, inside, threads);
  } else {
    d_acc = NearestDistances(ref_tree, inside, threads);
  }

  // Reference spacing: each reference point to its nearest other one.
  {
    std::vector<double> spacing(ref_points.size());
    core::ParallelFor(
        0, static_cast<int64_t>(ref_points.size()), threads, [&](int64_t b, int64_t e) {
          for (int64_t i = b; i < e; ++i) {
            const auto n = ref_tree.Nearest(ref_points[i], i);
            spacing[i] = n.index < 0 ? kNaN : std::sqrt(static_cast<double>(n.distance_sq));
          }
        });
    report.ref_spacing_median_mm = Quantile(spacing, 0.5);
  }

  // Completeness: reference points to the whole reconstruction.
  std::vector<double> d_comp;
  if (recon_points.empty()) {
    d_comp.assign(ref_points.size(), std::numeric_limits<double>::infinity());
    report.completeness_method = "nearest_point";
  } else if (recon_mesh && options.completeness_from_samples) {
    const std::vector<Eigen::Vector3f> dense =
        SampleMesh(recon_vertices, recon.faces, options.completeness_sample_density_per_mm2,
                   options.seed + 2, options, recon_name);
    d_comp = NearestDistances(PointKdTree(dense), ref_points, threads);
    report.completeness_method = "surface_sample";
  } else if (recon_mesh) {
    d_comp = SurfaceDistances(TriangleBvh(recon_vertices, recon.faces), ref_points, threads);
    report.completeness_method = "point_to_triangle";
  } else {
    d_comp = NearestDistances(PointKdTree(recon_points), ref_points, threads);
    report.completeness_method = "nearest_point";
  }

  for (const double t : options.thresholds_mm) {
    ThresholdScores s;
    s.threshold_mm = t;
    s.precision = d_acc.empty() ? 0.0 : FractionAtMost(d_acc, t);
    s.completeness = FractionAtMost(d_comp, t);
    s.fscore = s.precision + s.completeness > 0.0
                   ? 2.0 * s.precision * s.completeness / (s.precision + s.completeness)
                   : 0.0;
    report.scores.push_back(s);
  }
  report.acc_mean_mm = Mean(d_acc);
  report.acc_median_mm = Quantile(d_acc, 0.5);
  report.acc_p90_mm = Quantile(d_acc, 0.9);
  report.comp_median_mm = Quantile(d_comp, 0.5);
  report.seconds = watch.ElapsedSeconds();
  return report;
}

}  // namespace

CloudEvalReport EvaluateReconstruction(const io::Mesh& recon, const io::Mesh& reference,
                                       const CloudEvalOptions& options) {
  return Evaluate(recon, reference, options, "reconstruction", "reference");
}

CloudEvalReport EvaluateReconstructionFiles(const std::filesystem::path& recon,
                                            const std::filesystem::path& reference,
                                            const CloudEvalOptions& options) {
  options.Check();
  const io::Mesh recon_mesh = io::ReadPly(recon);
  const io::Mesh reference_mesh = io::ReadPly(reference);
  CloudEvalReport report =
      Evaluate(recon_mesh, reference_mesh, options, recon.string(), reference.string());
  report.recon = recon.string();
  report.reference = reference.string();
  return report;
}

std::string CloudEvalReport::BriefReport() const {
  char buf[512];
  std::string out;
  std::snprintf(buf, sizeof(buf),
                "%s with %lld points (%lld in box, %lld outside) vs %lld reference points "
                "(spacing %.4g mm)\n",
                kind.c_str(), static_cast<long long>(n_recon_pts), static_cast<long long>(n_in_box),
                static_cast<long long>(n_outside_box), static_cast<long long>(n_ref_pts),
                ref_spacing_median_mm);
  out += buf;
  std::snprintf(buf, sizeof(buf), "accuracy: median %.4g mm, mean %.4g mm, p90 %.4g mm\n",
                acc_median_mm, acc_mean_mm, acc_p90_mm);
  out += buf;
  std::snprintf(buf, sizeof(buf), "completeness (%s): median %.4g mm\n",
                completeness_method.c_str(), comp_median_mm);
  out += buf;
  for (const ThresholdScores& s : scores) {
    std::snprintf(buf, sizeof(buf), "  @%g mm: precision %.4f, completeness %.4f, F %.4f\n",
                  s.threshold_mm, s.precision, s.completeness, s.fscore);
    out += buf;
  }
  std::snprintf(buf, sizeof(buf), "evaluated in %.3f s", seconds);
  return out + buf;
}

std::string ToJson(const CloudEvalReport& r) {
  core::Json json = {{"recon", r.recon},
                     {"reference", r.reference},
                     {"kind", r.kind},
                     {"n_recon_pts", r.n_recon_pts},
                     {"n_in_box", r.n_in_box},
                     {"n_outside_box", r.n_outside_box},
                     {"frac_outside_box", r.frac_outside_box},
                     {"box_margin", r.box_margin},
                     {"n_ref_pts", r.n_ref_pts}};
  if (r.kind == "mesh") json["n_triangles"] = r.n_triangles;
  json["ref_spacing_median_mm"] = r.ref_spacing_median_mm;
  json["acc_median_mm"] = r.acc_median_mm;
  json["acc_mean_mm"] = r.acc_mean_mm;
  json["acc_p90_mm"] = r.acc_p90_mm;
  json["comp_median_mm"] = r.comp_median_mm;
  for (const ThresholdScores& s : r.scores) {
    const std::string t = FormatG(s.threshold_mm);
    json["precision@" + t + "mm"] = r.has_accuracy() ? core::Json(s.precision) : core::Json();
    json["completeness@" + t + "mm"] = s.completeness;
    json["fscore@" + t + "mm"] = s.fscore;
  }
  json["box_min_mm"] = {r.box_min_mm.x(), r.box_min_mm.y(), r.box_min_mm.z()};
  json["box_max_mm"] = {r.box_max_mm.x(), r.box_max_mm.y(), r.box_max_mm.z()};
  json["comp_method"] = r.completeness_method;
  return core::DumpJson(json);
}

}  // namespace dome::eval
