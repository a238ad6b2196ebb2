#include "calib/calibrate.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "calib/target.h"
#include "core/error.h"
#include "core/json.h"
#include "core/parallel_for.h"
#include "core/timer.h"
#include "io/image_io.h"

namespace dome::calib {

namespace fs = std::filesystem;
using core::Require;

void CalibrateOptions::Check() const {
  detector.Check();
  init.Check();
  Require(max_function_evaluations > 0, "--max-evaluations", "must be positive");
  Require(min_stage2_points >= 5, "--min-floor-marks",
          "must be at least 5 (Tsai's coplanar minimum)");
  Require(min_plain_mark_px >= 0, "min_plain_mark_px", "must be >= 0 (pixels)");
  Require(outlier_px > 0, "--outlier-px", "must be positive (pixels)");
  Require(flag_rms_px > 0 && flag_max_px > 0, "--flag-rms-px/--flag-max-px",
          "must be positive (pixels)");
  Require(worst_points >= 0, "worst_points", "must be >= 0");
  Require(max_stage1_views >= 0, "max_stage1_views", "must be >= 0 (0 = all)");
}

namespace {

RefineOptions Refine(const CalibrateOptions& o, bool intrinsics, bool centre) {
  RefineOptions r;
  r.refine_focal = r.refine_kappa1 = r.refine_sx = intrinsics;
  r.refine_centre = intrinsics && centre;
  r.max_function_evaluations = o.max_function_evaluations;
  return r;
}

struct LoadedView {
  std::string where;           // the view file
  std::string detector_error;  // why no points were found, when none were
  std::vector<Correspondence> points;
  StageReport report;
  Target target;
  GridLayout layout;  // detected dots only
  cv::Mat gray;       // the image, when its dots were detected
};

LoadedView LoadView(const fs::path& view_path, const CalibrateOptions& options) {
  Require(fs::exists(view_path), view_path.string(), "calibration view file does not exist");
  const CalibView view = ReadCalibView(view_path);
  const Target target = ReadTarget(view.target);
  LoadedView out;
  out.where = view_path.string();
  std::vector<ImagePoint> points;
  GridLayout layout;
  if (options.use_stored_points) {
    points = view.points;
    Require(fs::exists(view.image), view_path.string() + ": image",
            fmt::format("calibration image {} does not exist", view.image.string()));
  } else {
    Require(fs::exists(view.image), view_path.string() + ": image",
            fmt::format("calibration image {} does not exist", view.image.string()));
    out.gray = io::ReadImage(view.image, io::ImageMode::kGray8);
    layout = InferGridLayout(target);
    try {
      const DotDetection det =
          DetectDotTarget(out.gray, target, layout, options.detector, view.image.string());
      points = det.points;
      out.report.blobs = det.blobs;
      out.report.missing_ids = det.missing_ids;
    } catch (const core::InputError& e) {
      out.detector_error = e.what();  // no points: the stage's point-count check reports it
    }
  }
  for (const auto& p : points) {
    const int i = target.Find(p.id);
    Require(i >= 0, view_path.string() + ": points",
            fmt::format("image point id {} is not in the target {}", p.id, target.path));
    Correspondence c;
    c.id = p.id;
    c.target_mm = target.points[i].position_mm;
    c.pixel = c.detected_px = p.pixel;
    out.points.push_back(c);
  }
  // Detected dots: their plane and size, to undo the shift of their centroids.
  if (options.correct_dot_centroids) {
    for (const Grid& grid : layout.grids) {
      for (size_t cell = 0; cell < grid.ids.size(); ++cell) {
        for (auto& c : out.points) {
          if (c.id != grid.ids[cell]) continue;
          c.marker_normal = grid.normal;
          c.marker_radius_mm = cell == 0 ? target.key_marker_radius_mm : target.marker_radius_mm;
        }
      }
    }
    for (auto& c : out.points) {
      if (std::binary_search(layout.plain_ids.begin(), layout.plain_ids.end(), c.id)) {
        c.marker_normal = layout.grids[0].normal;
        c.marker_radius_mm = target.marker_radius_mm;
      }
    }
  }
  out.report.detected = static_cast<int>(out.points.size());
  out.target = target;
  out.layout = layout;
  return out;
}

// The target's plain marks (calib/target.h) among the image's dark blobs: each mark
// is predicted by the camera (its intrinsics and the view's pose from the grids, with
// the shift of the dot's centroid) and taken when an unclaimed blob lies within the
// detector's match tolerance of the local spacing of the marks' images; the pose is
// refitted (intrinsics fixed) and the marks predicted again until no more are found.
// Marks not found join the report's missing ids.
void AddPlainMarks(const LoadedView& loaded, const CalibrateOptions& options,
                   geometry::TsaiCamera* cam, std::vector<View>* views, StageReport* report) {
  const GridLayout& layout = loaded.layout;
  if (layout.plain_ids.empty() || loaded.gray.empty()) return;
  const Target& target = loaded.target;
  View& view = (*views)[0];
  const std::vector<Blob> blobs = DetectBlobs(loaded.gray, options.detector);
  std::vector<char> used(blobs.size(), 0);
  for (size_t b = 0; b < blobs.size(); ++b) {
    for (const auto& c : view.points) {
      if ((c.detected_px - blobs[b].centre).norm() < 1e-6) used[b] = 1;
    }
    if (blobs[b].cut) used[b] = 1;  // centroid biased by the border
  }
  const Eigen::Vector3d normal = layout.grids[0].normal;
  const double radius = target.marker_radius_mm;
  std::vector<int> pending = layout.plain_ids;
  for (int round = 0; round < 6 && !pending.empty(); ++round) {
    geometry::TsaiCamera posed = *cam;
    posed.rotation = view.rotation;
    posed.translation_mm = view.translation_mm;
    // Every target point's image, for the local spacing.
    std::vector<std::pair<int, Eigen::Vector2d>> images;
    for (const auto& p : target.points) {
      Eigen::Vector2d px;
      if (posed.Project(p.position_mm, &px)) images.emplace_back(p.id, px);
    }
    const double fx = cam->focal_mm * cam->sx / cam->sensor.dpx_mm();
    std::vector<int> still;
    std::vector<Correspondence> found;
    for (const int id : pending) {
      const Eigen::Vector3d& position = target.points[target.Find(id)].position_mm;
      const double z = posed.WorldToCamera(position).z();
      Eigen::Vector2d px;
      if (z <= 0 || !posed.Project(position, &px)) {
        still.push_back(id);
        continue;
      }
      // the dot's image, narrowest: its diameter foreshortened by the viewing angle
      const Eigen::Vector3d ray = position - posed.CentreWorld();
      if (2.0 * radius * fx / z * std::abs(normal.dot(ray.normalized())) <
          options.min_plain_mark_px) {
        still.push_back(id);
        continue;
      }
      px += DotCentroidOffsetPx(*cam, view, position, normal, radius);
      const double margin = radius * fx / z + 1.0;  // the whole dot inside the image
      double spacing = std::numeric_limits<double>::infinity();
      for (const auto& [other, image] : images) {
        if (other != id) spacing = std::min(spacing, (image - px).norm());
      }
      int best = -1;
      double best_d = options.detector.match_tolerance * spacing;
      if (px.x() >= margin - 0.5 && px.y() >= margin - 0.5 &&
          px.x() <= cam->width_px - 0.5 - margin && px.y() <= cam->height_px - 0.5 - margin) {
        for (size_t b = 0; b < blobs.size(); ++b) {
          const double d = (blobs[b].centre - px).norm();
          if (!used[b] && d < best_d) {
            best_d = d;
            best = static_cast<int>(b);
          }
        }
      }
      if (best < 0) {
        still.push_back(id);
        continue;
      }
      used[best] = 1;
      Correspondence c;
      c.id = id;
      c.target_mm = position;
      c.pixel = c.detected_px = blobs[best].centre;
      if (options.correct_dot_centroids) {
        c.marker_normal = normal;
        c.marker_radius_mm = radius;
      }
      found.push_back(c);
    }
    pending = still;
    if (found.empty()) break;
    report->detected += static_cast<int>(found.size());
    view.points.insert(view.points.end(), found.begin(), found.end());
    report->refine = RefineCamera(cam, views, Refine(options, false, false), loaded.where);
    if (options.correct_dot_centroids) {
      CorrectDotCentroids(*cam, &view);
      report->refine = RefineCamera(cam, views, Refine(options, false, false), loaded.where);
    }
  }
  report->missing_ids.insert(report->missing_ids.end(), pending.begin(), pending.end());
  std::sort(report->missing_ids.begin(), report->missing_ids.end());
}

void Measure(const geometry::TsaiCamera& cam, const View& view, StageReport* report) {
  double sum = 0, mx = 0;
  for (const auto& c : view.points) {
    const double e = ReprojectionErrorPx(cam, view, c);
    sum += e * e;
    mx = std::max(mx, e);
  }
  report->points = static_cast<int>(view.points.size());
  report->rms_px = view.points.empty() ? 0.0 : std::sqrt(sum / view.points.size());
  report->max_px = mx;
}

// Over several views of one stage.
void MeasureAll(const geometry::TsaiCamera& cam, const std::vector<View>& views,
                StageReport* report) {
  double sum = 0, mx = 0;
  int count = 0;
  for (const auto& view : views) {
    StageReport one;
    Measure(cam, view, &one);
    sum += one.rms_px * one.rms_px * one.points;
    mx = std::max(mx, one.max_px);
    count += one.points;
  }
  report->points = count;
  report->rms_px = count ? std::sqrt(sum / count) : 0.0;
  report->max_px = mx;
}

// Removes points beyond the outlier bound (from the view's own RMS); returns true when
// any was removed.
bool RejectOutliers(const geometry::TsaiCamera& cam, View* view, double outlier_px,
                    StageReport* report) {
  StageReport measured;
  Measure(cam, *view, &measured);
  const double bound = std::max(outlier_px, 4.0 * measured.rms_px);
  std::vector<Correspondence> kept;
  bool removed = false;
  for (const auto& c : view->points) {
    if (ReprojectionErrorPx(cam, *view, c) > bound) {
      report->rejected_ids.push_back(c.id);
      removed = true;
    } else {
      kept.push_back(c);
    }
  }
  view->points = std::move(kept);
  return removed;
}

}  // namespace

std::vector<fs::path> ViewPaths(const fs::path& stage_dir, const std::string& camera) {
  std::vector<fs::path> paths{stage_dir / (camera + ".json")};
  for (int pose = 1;; ++pose) {
    const fs::path p = stage_dir / (camera + "." + std::to_string(pose) + ".json");
    std::error_code ec;
    if (!fs::exists(p, ec)) break;
    paths.push_back(p);
  }
  return paths;
}

CameraReport CalibrateCamera(const geometry::RigCamera& prior, const fs::path& stage1_view,
                             const fs::path& stage2_view, const CalibrateOptions& options,
                             geometry::TsaiCamera* calibrated) {
  return CalibrateCamera(prior, std::vector<fs::path>{stage1_view}, stage2_view, options,
                         calibrated);
}

// Dots narrower than this cannot be placed to the precision calibration needs, px:
// their centroids wander by a good part of a pixel, and Tsai's closed form then fails
// in ways that do not say why (points "behind the camera").
constexpr double kMinDotDiameterPx = 3.0;

// When the dots of a view's image are too small to calibrate from, why; "" otherwise.
std::string SmallDotsHint(const fs::path& view_path, const DotDetectorOptions& detector) {
  try {
    const CalibView view = ReadCalibView(view_path);
    const cv::Mat gray = io::ReadImage(view.image, io::ImageMode::kGray8);
    std::vector<double> areas;
    for (const Blob& b : DetectBlobs(gray, detector)) {
      if (!b.cut) areas.push_back(b.area_px);
    }
    if (areas.empty()) return "";
    std::nth_element(areas.begin(), areas.begin() + areas.size() / 2, areas.end());
    const double diameter = 2.0 * std::sqrt(areas[areas.size() / 2] / M_PI);
    if (diameter >= kMinDotDiameterPx) return "";
    return fmt::format(
        "; the dots of {} ({}x{} px) are only {:.1f} px across, and calibration needs at "
        "least {:.0f} px to place their centres: capture or render the calibration images "
        "larger",
        view.image.string(), gray.cols, gray.rows, diameter, kMinDotDiameterPx);
  } catch (const core::InputError&) {
    return "";  // the error being explained names what is wrong with the view
  }
}

CameraReport CalibrateCamera(const geometry::RigCamera& prior,
                             const std::vector<fs::path>& stage1_views, const fs::path& stage2_view,
                             const CalibrateOptions& options, geometry::TsaiCamera* calibrated) {
  const geometry::TsaiCamera& known = prior.model;
  CameraReport report;
  report.id = known.id;
  CameraPrior cp{known.id, known.width_px, known.height_px, known.sensor};
  Require(!stage1_views.empty(), known.id, "no stage-1 view");

  // Stage 1: intrinsics from the 3D object. The first view must calibrate on its own;
  // the object's further poses add their points (each with its own pose) when their
  // dots are found and Tsai's closed form accepts them, and are reported otherwise.
  LoadedView s1 = LoadView(stage1_views[0], options);
  report.stage1 = s1.report;
  Require(s1.detector_error.empty(), s1.where,
          fmt::format("camera {}: no calibration points found ({})", known.id, s1.detector_error));
  geometry::TsaiCamera cam =
      TsaiInitNonCoplanar(cp, 0.5 * (known.width_px - 1), 0.5 * (known.height_px - 1), s1.points,
                          options.init, s1.where);
  std::vector<View> views1{View{"stage1", s1.points, cam.rotation, cam.translation_mm}};
  RefineCamera(&cam, &views1, Refine(options, true, false), s1.where);
  report.stage1.refine = RefineCamera(&cam, &views1, Refine(options, true, true), s1.where);
  for (size_t v = 1; v < stage1_views.size(); ++v) {
    const std::string name = "stage1." + std::to_string(v);
    try {
      LoadedView extra = LoadView(stage1_views[v], options);
      Require(extra.detector_error.empty(), extra.where, extra.detector_error);
      geometry::TsaiCamera posed =
          TsaiInitNonCoplanar(cp, cam.cx_px, cam.cy_px, extra.points, options.init, extra.where);
      // The pose alone under the first view's intrinsics, before it joins them.
      std::vector<View> one{View{name, extra.points, posed.rotation, posed.translation_mm}};
      geometry::TsaiCamera fixed = cam;
      RefineCamera(&fixed, &one, Refine(options, false, false), extra.where);
      StageReport check;
      Measure(fixed, one[0], &check);
      Require(check.rms_px <= 4.0 * options.flag_rms_px, extra.where,
              fmt::format("RMS {:.3f} px under the first view's intrinsics", check.rms_px));
      report.stage1.detected += extra.report.detected;
      report.stage1.blobs += extra.report.blobs;
      views1.push_back(one[0]);
    } catch (const core::InputError& e) {
      report.stage1.skipped_views.push_back(fmt::format("{}: {}", name, e.what()));
    }
  }
  report.stage1.views = static_cast<int>(views1.size());
  if (views1.size() > 1) {
    report.stage1.refine = RefineCamera(&cam, &views1, Refine(options, true, true), s1.where);
  }
  if (options.correct_dot_centroids) {
    for (auto& view : views1) CorrectDotCentroids(cam, &view);
    report.stage1.refine = RefineCamera(&cam, &views1, Refine(options, true, true), s1.where);
  }
  for (int pass = 0; pass < 3; ++pass) {
    bool removed = false;
    for (auto& view : views1) {
      removed = RejectOutliers(cam, &view, options.outlier_px, &report.stage1) || removed;
      Require(static_cast<int>(view.points.size()) >= options.init.min_points_noncoplanar, s1.where,
              fmt::format("{}: only {} points left after rejecting outliers", view.name,
                          view.points.size()));
    }
    if (!removed) break;
    report.stage1.refine = RefineCamera(&cam, &views1, Refine(options, true, true), s1.where);
  }
  MeasureAll(cam, views1, &report.stage1);
  report.sigma = report.stage1.refine.sigma;

  // Stage 2: pose from the floor marks, intrinsics fixed.
  LoadedView s2 = LoadView(stage2_view, options);
  report.stage2 = s2.report;
  Require(static_cast<int>(s2.points.size()) >= options.min_stage2_points, s2.where,
          fmt::format("camera {} sees {} floor marks; stage 2 needs at least {}{}", known.id,
                      s2.points.size(), options.min_stage2_points,
                      s2.detector_error.empty() ? "" : " (" + s2.detector_error + ")"));
  const geometry::TsaiCamera posed =
      TsaiInitCoplanar(cam, s2.points, /*fix_focal=*/true, options.init, s2.where);
  std::vector<View> views2{View{"stage2", s2.points, posed.rotation, posed.translation_mm}};
  report.stage2.refine = RefineCamera(&cam, &views2, Refine(options, false, false), s2.where);
  if (options.correct_dot_centroids) {
    CorrectDotCentroids(cam, &views2[0]);
    report.stage2.refine = RefineCamera(&cam, &views2, Refine(options, false, false), s2.where);
  }
  AddPlainMarks(s2, options, &cam, &views2, &report.stage2);
  for (int pass = 0;
       pass < 3 && RejectOutliers(cam, &views2[0], options.outlier_px, &report.stage2); ++pass) {
    Require(static_cast<int>(views2[0].points.size()) >= options.min_stage2_points, s2.where,
            fmt::format("camera {}: only {} floor marks left after rejecting outliers; stage 2 "
                        "needs at least {}",
                        known.id, views2[0].points.size(), options.min_stage2_points));
    report.stage2.refine = RefineCamera(&cam, &views2, Refine(options, false, false), s2.where);
  }
  Measure(cam, views2[0], &report.stage2);
  report.sigma.rotation_deg = report.stage2.refine.sigma.rotation_deg;
  report.sigma.translation_mm = report.stage2.refine.sigma.translation_mm;

  std::vector<View> both = views1;
  both.push_back(views2[0]);
  // A floor view that does not fit (misidentified marks) must not pull the intrinsics
  // away from stage 1: the joint refinement runs only when stage 2 is within bounds.
  if (options.joint_refinement && report.stage2.rms_px <= options.flag_rms_px) {
    RefineSummary joint = RefineCamera(&cam, &both, Refine(options, true, true), known.id);
    if (options.correct_dot_centroids) {
      for (auto& view : both) CorrectDotCentroids(cam, &view);
      joint = RefineCamera(&cam, &both, Refine(options, true, true), known.id);
    }
    report.sigma = joint.sigma;  // the last view is the floor: its pose is the camera's
  }
  MeasureAll(cam, std::vector<View>(both.begin(), both.end() - 1), &report.stage1);
  Measure(cam, both.back(), &report.stage2);

  // Final errors and the worst points.
  double sum = 0, mx = 0;
  int count = 0;
  std::vector<PointError> all;
  for (const auto& view : both) {
    for (const auto& c : view.points) {
      const double e = ReprojectionErrorPx(cam, view, c);
      sum += e * e;
      mx = std::max(mx, e);
      ++count;
      all.push_back({view.name, c.id, e});
    }
  }
  std::sort(all.begin(), all.end(),
            [](const auto& a, const auto& b) { return a.error_px > b.error_px; });
  all.resize(std::min<size_t>(all.size(), options.worst_points));
  report.worst = all;
  report.rms_px = count ? std::sqrt(sum / count) : 0.0;
  report.max_px = mx;
  std::vector<std::string> reasons;
  if (report.rms_px > options.flag_rms_px)
    reasons.push_back(fmt::format("RMS {:.3f} px > {}", report.rms_px, options.flag_rms_px));
  if (report.max_px > options.flag_max_px)
    reasons.push_back(fmt::format("max {:.3f} px > {}", report.max_px, options.flag_max_px));
  if (!report.stage1.rejected_ids.empty() || !report.stage2.rejected_ids.empty()) {
    reasons.push_back(fmt::format("{} outliers rejected", report.stage1.rejected_ids.size() +
                                                              report.stage2.rejected_ids.size()));
  }
  report.flagged = !reasons.empty();
  for (size_t i = 0; i < reasons.size(); ++i) report.flag_reason += (i ? "; " : "") + reasons[i];

  cam.rotation = both.back().rotation;
  cam.translation_mm = both.back().translation_mm;
  *calibrated = cam;
  return report;
}

CalibrationResult CalibrateTake(const fs::path& take_dir, const geometry::Rig& prior,
                                const CalibrateOptions& options) {
  options.Check();
  core::Stopwatch stopwatch;
  const fs::path calib = take_dir / "calib";
  Require(fs::is_directory(calib), calib.string(),
          "no calibration folder (expected calib/stage1, calib/stage2)");
  Require(!prior.cameras.empty(), "rig", "the prior rig has no cameras");
  const int n = static_cast<int>(prior.cameras.size());
  CalibrationResult result;
  result.rig = prior;
  result.rig.source = "dome calibrate";
  result.cameras.resize(n);
  core::ParallelFor(0, n, options.threads, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      const std::string& id = prior.cameras[i].model.id;
      try {
        std::vector<fs::path> stage1 = ViewPaths(calib / "stage1", id);
        if (options.max_stage1_views > 0 &&
            static_cast<int>(stage1.size()) > options.max_stage1_views) {
          stage1.resize(options.max_stage1_views);
        }
        result.cameras[i] =
            CalibrateCamera(prior.cameras[i], stage1, calib / "stage2" / (id + ".json"), options,
                            &result.rig.cameras[i].model);
      } catch (const core::InputError& e) {
        // Tiny dots fail deep inside the solution: say that they are the cause.
        std::string hint;
        try {
          const std::vector<fs::path> views = ViewPaths(calib / "stage1", id);
          if (!views.empty()) hint = SmallDotsHint(views[0], options.detector);
        } catch (const core::InputError&) {
          // No view to look at: the error says so itself.
        }
        std::string what = e.what();
        if (!e.where().empty() && what.rfind(e.where() + ": ", 0) == 0) {
          what = what.substr(e.where().size() + 2);
        }
        if (!options.keep_going) {
          if (hint.empty()) throw;
          throw core::InputError(e.where(), what + hint);
        }
        CameraReport& r = result.cameras[i];
        r.id = id;
        r.flagged = r.failed = true;
        r.flag_reason = std::string("calibration failed: ") + e.what() + hint;
      }
    }
  });
  result.seconds = stopwatch.ElapsedSeconds();
  return result;
}

std::string CalibrationResult::BriefReport() const {
  std::string s = fmt::format("calibrated {} cameras in {:.1f} s\n", cameras.size(), seconds);
  s += "camera  stage1 pts  rms     stage2 pts  rms     all rms  max     f sd(mm)  flag\n";
  int flagged = 0;
  for (const auto& c : cameras) {
    s += fmt::format("{:<7} {:>10}  {:.3f}   {:>10}  {:.3f}   {:.3f}    {:.3f}   {:.2e}  {}\n",
                     c.id, c.stage1.points, c.stage1.rms_px, c.stage2.points, c.stage2.rms_px,
                     c.rms_px, c.max_px, c.sigma.focal_mm, c.flagged ? c.flag_reason : "");
    flagged += c.flagged;
  }
  s += fmt::format("{} camera(s) flagged\n", flagged);
  return s;
}

namespace {
core::Json StageJson(const StageReport& r) {
  return {{"views", r.views},
          {"points", r.points},
          {"detected", r.detected},
          {"blobs", r.blobs},
          {"missing_ids", r.missing_ids},
          {"rejected_ids", r.rejected_ids},
          {"skipped_views", r.skipped_views},
          {"rms_px", r.rms_px},
          {"max_px", r.max_px},
          {"lm_iterations", r.refine.iterations},
          {"lm_converged", r.refine.converged}};
}
}  // namespace

std::string CalibrationResult::ReportJson() const {
  core::Json list = core::Json::array();
  for (const auto& c : cameras) {
    core::Json worst = core::Json::array();
    for (const auto& w : c.worst)
      worst.push_back({{"stage", w.stage}, {"id", w.id}, {"error_px", w.error_px}});
    const auto& sg = c.sigma;
    list.push_back(
        {{"id", c.id},
         {"rms_px", c.rms_px},
         {"max_px", c.max_px},
         {"flagged", c.flagged},
         {"failed", c.failed},
         {"flag_reason", c.flag_reason},
         {"stage1", StageJson(c.stage1)},
         {"stage2", StageJson(c.stage2)},
         {"worst_points", std::move(worst)},
         {"sigma",
          {{"focal_mm", sg.focal_mm},
           {"kappa1_per_mm2", sg.kappa1_per_mm2},
           {"cx_px", sg.cx_px},
           {"cy_px", sg.cy_px},
           {"sx", sg.sx},
           {"rotation_deg", {sg.rotation_deg(0), sg.rotation_deg(1), sg.rotation_deg(2)}},
           {"translation_mm",
            {sg.translation_mm(0), sg.translation_mm(1), sg.translation_mm(2)}}}}});
  }
  const core::Json j = {{"format_version", 1}, {"seconds", seconds}, {"cameras", std::move(list)}};
  return core::DumpJson(j, 1) + "\n";
}

}  // namespace dome::calib
