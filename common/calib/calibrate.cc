#include "calib/calibrate.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "calib/target.h"
#include "core/error.h"
#include "core/parallel_for.h"
#include "core/timer.h"
#include "eval/json_writer.h"
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
  Require(outlier_px > 0, "--outlier-px", "must be positive (pixels)");
  Require(flag_rms_px > 0 && flag_max_px > 0, "--flag-rms-px/--flag-max-px",
          "must be positive (pixels)");
  Require(worst_points >= 0, "worst_points", "must be >= 0");
}

namespace {

struct LoadedView {
  std::string where;           // the view file
  std::string detector_error;  // why no points were found, when none were
  std::vector<Correspondence> points;
  StageReport report;
};

LoadedView LoadView(const fs::path& view_path, const CalibrateOptions& options) {
  Require(fs::exists(view_path), view_path.string(), "calibration view file does not exist");
  const CalibViewFile view = ReadCalibView(view_path);
  const Target target = ReadTarget(view.target);
  LoadedView out;
  out.where = view_path.string();
  std::vector<ImagePoint> points;
  if (options.use_stored_points) {
    points = view.points;
    Require(fs::exists(view.image), view_path.string() + ": image",
            fmt::format("calibration image {} does not exist", view.image.string()));
  } else {
    Require(fs::exists(view.image), view_path.string() + ": image",
            fmt::format("calibration image {} does not exist", view.image.string()));
    const cv::Mat gray = io::ReadImage(view.image, io::ImageMode::kGray8);
    const GridLayout layout = InferGridLayout(target);
    try {
      const DotDetection det =
          DetectDotTarget(gray, target, layout, options.detector, view.image.string());
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
    out.points.push_back({p.id, target.points[i].position_mm, p.pixel});
  }
  out.report.detected = static_cast<int>(out.points.size());
  return out;
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

// Removes points beyond the outlier bound; returns true when any was removed.
bool RejectOutliers(const geometry::TsaiCamera& cam, View* view, double outlier_px,
                    StageReport* report) {
  Measure(cam, *view, report);
  const double bound = std::max(outlier_px, 4.0 * report->rms_px);
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

RefineOptions Refine(const CalibrateOptions& o, bool intrinsics, bool centre) {
  RefineOptions r;
  r.refine_focal = r.refine_kappa1 = r.refine_sx = intrinsics;
  r.refine_centre = intrinsics && centre;
  r.max_function_evaluations = o.max_function_evaluations;
  return r;
}

}  // namespace

CameraReport CalibrateCamera(const take::RigCamera& prior, const fs::path& stage1_view,
                             const fs::path& stage2_view, const CalibrateOptions& options,
                             geometry::TsaiCamera* calibrated) {
  const geometry::TsaiCamera& known = prior.model;
  CameraReport report;
  report.id = known.id;
  CameraPrior cp{known.id, known.width_px, known.height_px, known.sensor};

  // Stage 1: intrinsics from the 3D object.
  LoadedView s1 = LoadView(stage1_view, options);
  report.stage1 = s1.report;
  Require(s1.detector_error.empty(), s1.where,
          fmt::format("camera {}: no calibration points found ({})", known.id, s1.detector_error));
  geometry::TsaiCamera cam =
      TsaiInitNonCoplanar(cp, 0.5 * (known.width_px - 1), 0.5 * (known.height_px - 1), s1.points,
                          options.init, s1.where);
  View v1{"stage1", s1.points, cam.rotation, cam.translation_mm};
  std::vector<View> views1{v1};
  RefineCamera(&cam, &views1, Refine(options, true, false), s1.where);
  report.stage1.refine = RefineCamera(&cam, &views1, Refine(options, true, true), s1.where);
  for (int pass = 0;
       pass < 3 && RejectOutliers(cam, &views1[0], options.outlier_px, &report.stage1); ++pass) {
    Require(static_cast<int>(views1[0].points.size()) >= options.init.min_points_noncoplanar,
            s1.where,
            fmt::format("only {} points left after rejecting outliers", views1[0].points.size()));
    report.stage1.refine = RefineCamera(&cam, &views1, Refine(options, true, true), s1.where);
  }
  Measure(cam, views1[0], &report.stage1);
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

  std::vector<View> both{views1[0], views2[0]};
  // A floor view that does not fit (misidentified marks) must not pull the intrinsics
  // away from stage 1: the joint refinement runs only when stage 2 is within bounds.
  if (options.joint_refinement && report.stage2.rms_px <= options.flag_rms_px) {
    const RefineSummary joint = RefineCamera(&cam, &both, Refine(options, true, true), known.id);
    report.sigma = joint.sigma;  // the last view is the floor: its pose is the camera's
  }
  Measure(cam, both[0], &report.stage1);
  Measure(cam, both[1], &report.stage2);

  // Final errors and the worst points.
  double sum = 0, mx = 0;
  int count = 0;
  std::vector<PointError> all;
  for (int v = 0; v < 2; ++v) {
    for (const auto& c : both[v].points) {
      const double e = ReprojectionErrorPx(cam, both[v], c);
      sum += e * e;
      mx = std::max(mx, e);
      ++count;
      all.push_back({v == 0 ? "stage1" : "stage2", c.id, e});
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

  cam.rotation = both[1].rotation;
  cam.translation_mm = both[1].translation_mm;
  *calibrated = cam;
  return report;
}

CalibrationResult CalibrateTake(const fs::path& take_dir, const take::Rig& prior,
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
        result.cameras[i] = CalibrateCamera(prior.cameras[i], calib / "stage1" / (id + ".json"),
                                            calib / "stage2" / (id + ".json"), options,
                                            &result.rig.cameras[i].model);
      } catch (const core::InputError& e) {
        if (!options.keep_going) throw;
        CameraReport& r = result.cameras[i];
        r.id = id;
        r.flagged = r.failed = true;
        r.flag_reason = std::string("calibration failed: ") + e.what();
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
std::string IntList(const std::vector<int>& v) {
  std::string s = "[";
  for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + std::to_string(v[i]);
  return s + "]";
}
std::string StageJson(const StageReport& r) {
  using eval::JsonNumber;
  return fmt::format(
      "{{\"points\": {}, \"detected\": {}, \"blobs\": {}, \"missing_ids\": {}, \"rejected_ids\": "
      "{}, "
      "\"rms_px\": {}, \"max_px\": {}, \"lm_iterations\": {}, \"lm_converged\": {}}}",
      r.points, r.detected, r.blobs, IntList(r.missing_ids), IntList(r.rejected_ids),
      JsonNumber(r.rms_px), JsonNumber(r.max_px), r.refine.iterations,
      r.refine.converged ? "true" : "false");
}
}  // namespace

std::string CalibrationResult::ReportJson() const {
  using eval::JsonNumber;
  using eval::JsonQuote;
  std::string s = fmt::format("{{\"format_version\": 1, \"seconds\": {}, \"cameras\": [\n",
                              JsonNumber(seconds));
  for (size_t i = 0; i < cameras.size(); ++i) {
    const auto& c = cameras[i];
    std::string worst = "[";
    for (size_t w = 0; w < c.worst.size(); ++w) {
      worst +=
          fmt::format("{}{{\"stage\": {}, \"id\": {}, \"error_px\": {}}}", w ? ", " : "",
                      JsonQuote(c.worst[w].stage), c.worst[w].id, JsonNumber(c.worst[w].error_px));
    }
    worst += "]";
    const auto& sg = c.sigma;
    s += fmt::format(
        "  {{\"id\": {}, \"rms_px\": {}, \"max_px\": {}, \"flagged\": {}, \"failed\": {}, "
        "\"flag_reason\": {},\n"
        "   \"stage1\": {},\n   \"stage2\": {},\n   \"worst_points\": {},\n"
        "   \"sigma\": {{\"focal_mm\": {}, \"kappa1_per_mm2\": {}, \"cx_px\": {}, \"cy_px\": {}, "
        "\"sx\": {}, "
        "\"rotation_deg\": [{}, {}, {}], \"translation_mm\": [{}, {}, {}]}}}}{}\n",
        JsonQuote(c.id), JsonNumber(c.rms_px), JsonNumber(c.max_px), c.flagged ? "true" : "false",
        c.failed ? "true" : "false", JsonQuote(c.flag_reason), StageJson(c.stage1),
        StageJson(c.stage2), worst, JsonNumber(sg.focal_mm), JsonNumber(sg.kappa1_per_mm2),
        JsonNumber(sg.cx_px), JsonNumber(sg.cy_px), JsonNumber(sg.sx),
        JsonNumber(sg.rotation_deg(0)), JsonNumber(sg.rotation_deg(1)),
        JsonNumber(sg.rotation_deg(2)), JsonNumber(sg.translation_mm(0)),
        JsonNumber(sg.translation_mm(1)), JsonNumber(sg.translation_mm(2)),
        i + 1 < cameras.size() ? "," : "");
  }
  s += "]}\n";
  return s;
}

}  // namespace dome::calib
