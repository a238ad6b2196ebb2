// Acceptance measurement of `dome calibrate` on a synthetic take (issue 5): calibrates
// the take from TAKE/calib/ and compares every camera with the true rig.json.
//
//   build-calib/bin/dome synth --preset paper --instants 1 --no-tape --out /tmp/calib_paper
//   build-calib/bin/calib_bench_dome /tmp/calib_paper [--stored-points] [--no-joint]
//       [--first-view-only] [--raw-centroids] [--synth] [--per-camera]
//
// --synth first writes that take (paper preset, 1 instant, no tape) into TAKE;
// --first-view-only uses one stage-1 image per camera; --raw-centroids fits the dots'
// centroids as detected (no perspective correction); --per-camera prints each
// camera's errors against the truth.
// Prints the detector's error against the renderer's true image points (per stage:
// the distance, and the mean signed x / y error, a bias, per image), then over the
// cameras: relative focal error, image-centre error (px), relative kappa1 error,
// camera-centre error (mm), rotation error (deg), RMS reprojection (px): median, 90th
// percentile and max.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "calib/calibrate.h"
#include "calib/detect.h"
#include "calib/target.h"
#include "core/error.h"
#include "io/image_io.h"
#include "schema/rig_json.h"
#include "synth/synth.h"

namespace {

void Row(const char* name, std::vector<double> v, const char* unit) {
  std::sort(v.begin(), v.end());
  auto q = [&](double f) {
    return v[std::min(v.size() - 1, static_cast<size_t>(f * (v.size() - 1) + 0.5))];
  };
  std::printf("%-22s median %-10.4g p90 %-10.4g max %-10.4g %s\n", name, q(0.5), q(0.9), v.back(),
              unit);
}

// The detector against the true image points of every view of a stage.
void DetectionErrors(const std::string& take, const dome::geometry::Rig& rig, const char* stage) {
  namespace calib = dome::calib;
  const std::string dir = take + "/calib/" + stage;
  const calib::Target target = calib::ReadTarget(dir + "/target.json");
  const calib::GridLayout layout = calib::InferGridLayout(target);
  std::vector<double> error, bias_x, bias_y;
  int views = 0, failed = 0;
  for (const auto& cam : rig.cameras) {
    const auto paths = calib::ViewPaths(dir, cam.model.id);
    for (const auto& path : paths) {
      const calib::CalibView view = calib::ReadCalibView(path);
      const cv::Mat gray = dome::io::ReadImage(view.image, dome::io::ImageMode::kGray8);
      ++views;
      try {
        const auto det = calib::DetectDotTarget(gray, target, layout, {}, view.image.string());
        double sx = 0, sy = 0;
        int n = 0;
        for (const auto& p : det.points) {
          for (const auto& t : view.points) {
            if (t.id != p.id) continue;
            const Eigen::Vector2d d = p.pixel - t.pixel;
            error.push_back(d.norm());
            sx += d.x();
            sy += d.y();
            ++n;
          }
        }
        if (n > 0) {
          bias_x.push_back(std::abs(sx / n));
          bias_y.push_back(std::abs(sy / n));
        }
      } catch (const dome::core::InputError&) {
        ++failed;
      }
    }
  }
  std::printf("\n%s detection against the true image points (%d images, %d without a grid):\n",
              stage, views, failed);
  if (error.empty()) return;
  Row("point error", error, "px");
  Row("|mean x error| per image", bias_x, "px");
  Row("|mean y error| per image", bias_y, "px");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s TAKE [--stored-points] [--no-joint]\n", argv[0]);
    return 1;
  }
  try {
    dome::calib::CalibrateOptions options;
    options.keep_going = true;
    bool first_view_only = false, synth = false, per_camera = false;
    for (int i = 2; i < argc; ++i) {
      if (!std::strcmp(argv[i], "--stored-points")) options.use_stored_points = true;
      if (!std::strcmp(argv[i], "--no-joint")) options.joint_refinement = false;
      if (!std::strcmp(argv[i], "--first-view-only")) first_view_only = true;
      if (!std::strcmp(argv[i], "--synth")) synth = true;
      if (!std::strcmp(argv[i], "--per-camera")) per_camera = true;
      if (!std::strcmp(argv[i], "--raw-centroids")) options.correct_dot_centroids = false;
    }
    const std::string take = argv[1];
    if (synth) {
      dome::synth::SynthOptions so;
      so.preset = "paper";
      so.instants = 1;
      so.write_tape = false;
      so.overwrite = true;
      std::fputs(dome::synth::GenerateTake(so, take).BriefReport().c_str(), stdout);
    }
    const dome::geometry::Rig truth = dome::schema::ReadRig(take + "/rig.json");
    DetectionErrors(take, truth, "stage1");
    DetectionErrors(take, truth, "stage2");
    if (first_view_only) options.max_stage1_views = 1;
    const auto result = dome::calib::CalibrateTake(take, truth, options);
    std::fputs(result.BriefReport().c_str(), stdout);
    for (const bool skip_flagged : {false, true}) {
      std::vector<double> f, c, k, pos, rot, rms, maxe, fsig, ksig, kz, tsig, rsig;
      int skipped = 0;
      for (size_t i = 0; i < truth.cameras.size(); ++i) {
        if (result.cameras[i].failed || (skip_flagged && result.cameras[i].flagged)) {
          ++skipped;
          continue;
        }
        const auto& t = truth.cameras[i].model;
        const auto& e = result.rig.cameras[i].model;
        f.push_back(std::abs(e.focal_mm / t.focal_mm - 1) * 100);
        c.push_back(std::hypot(e.cx_px - t.cx_px, e.cy_px - t.cy_px));
        k.push_back(std::abs(e.kappa1_per_mm2 / t.kappa1_per_mm2 - 1) * 100);
        pos.push_back((e.CentreWorld() - t.CentreWorld()).norm());
        rot.push_back(Eigen::AngleAxisd(e.rotation * t.rotation.transpose()).angle() * 180 / M_PI);
        rms.push_back(result.cameras[i].rms_px);
        maxe.push_back(result.cameras[i].max_px);
        if (!skip_flagged && per_camera) {
          std::printf(
              "camera %s: focal %.4f %%, centre %.3f px, kappa1 %.3f %%, position %.3f mm, "
              "rotation %.4f deg, stage 2 %d points (%d identified)\n",
              t.id.c_str(), f.back(), c.back(), k.back(), pos.back(), rot.back(),
              result.cameras[i].stage2.points, result.cameras[i].stage2.detected);
        }
        if (!skip_flagged && (pos.back() > 10.0 || rot.back() > 0.5)) {
          std::printf("camera %s: centre %.1f mm, rotation %.2f deg off\n", t.id.c_str(),
                      pos.back(), rot.back());
        }
        const auto& sg = result.cameras[i].sigma;
        tsig.push_back(sg.translation_mm.norm());
        rsig.push_back(sg.rotation_deg.norm());
        fsig.push_back(sg.focal_mm / t.focal_mm * 100);
        ksig.push_back(sg.kappa1_per_mm2 / std::abs(t.kappa1_per_mm2) * 100);
        kz.push_back(sg.kappa1_per_mm2 > 0
                         ? std::abs(e.kappa1_per_mm2 - t.kappa1_per_mm2) / sg.kappa1_per_mm2
                         : 0);
      }
      if (f.empty()) continue;
      std::printf("\nagainst the true rig, over %zu cameras (%d %s excluded):\n", f.size(), skipped,
                  skip_flagged ? "flagged or failed" : "failed");
      Row("focal length error", f, "% (goal < 0.1%)");
      Row("image centre error", c, "px (goal < 1 px)");
      Row("kappa1 error", k, "% (goal < 2%)");
      Row("camera centre error", pos, "mm (goal < 2 mm)");
      Row("rotation error", rot, "deg (goal < 0.05 deg)");
      Row("RMS reprojection", rms, "px (goal < 0.2 px)");
      Row("max reprojection", maxe, "px");
      Row("solver sigma of f", fsig, "% (1 sigma, from the LM covariance)");
      Row("solver sigma of kappa1", ksig, "% (1 sigma)");
      Row("kappa1 error / sigma", kz, "(consistent with noise when ~1)");
      Row("solver sigma of t", tsig, "mm (norm of the floor pose's 1-sigma translation)");
      Row("solver sigma of R", rsig, "deg (norm of its 1-sigma rotation vector)");
    }
    std::printf("time %.1f s\n", result.seconds);
    return 0;
  } catch (const dome::core::InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
