// `dome calibrate TAKE`: Tsai's two-stage calibration of the take's cameras from
// TAKE/calib/ (common/calib/calibrate.h). Writes the calibrated rig (default
// TAKE/rig.json) and a JSON report (default TAKE/calib/report.json); prints a summary.
// Exit status 0 when every camera is within bounds, 2 when some camera is flagged.
// `dome calibrate --points FILE --size W H --sensor NCX NFX DX DY [--out RIG]`: one
// camera from 3D-2D correspondences (calib/point_calibration.h), printed as Willson's
// ccal / ncal print it.
#include "calib/calibrate.h"

#include <cstdio>
#include <memory>
#include <string>

#include "calib/point_calibration.h"
#include "cli/commands.h"
#include "core/error.h"
#include "io/file_util.h"
#include "schema/rig_json.h"

namespace dome::cli {

void AddCalibrateCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand(
      "calibrate", "Calibrate a take's cameras from TAKE/calib/ (Tsai, two stages) into rig.json");
  struct Args {
    calib::CalibrateOptions options;
    std::string take, prior, out, report;
    bool no_joint = false;
    // --points: one camera from a correspondence file (calib/point_calibration.h).
    std::string points, id = "camera";
    std::vector<int> size;       // width height, px
    std::vector<double> sensor;  // ncx nfx dx_mm dy_mm
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("TAKE", args->take, "take folder with calib/stage1 and calib/stage2");
  cmd->add_option("--points", args->points,
                  "instead of a take: one camera from a file of x y z Xf Yf rows (world mm, "
                  "pixels), coplanar when every z is 0 (Willson's ccal) or not (ncal)");
  cmd->add_option("--size", args->size, "with --points: image width and height, px")->expected(2);
  cmd->add_option("--sensor", args->sensor,
                  "with --points: Tsai's sensor constants ncx nfx dx_mm dy_mm")
      ->expected(4);
  cmd->add_option("--id", args->id, "with --points: the camera's id")->capture_default_str();
  cmd->add_option(
      "--prior", args->prior,
      "rig giving the cameras' ids, image sizes and sensor constants (default TAKE/rig.json)");
  cmd->add_option("--out", args->out, "rig file to write (default TAKE/rig.json)");
  cmd->add_option("--report", args->report,
                  "report file to write (default TAKE/calib/report.json)");
  cmd->add_flag("--no-joint", args->no_joint, "skip the final joint refinement of both stages");
  cmd->add_flag("--stored-points", args->options.use_stored_points,
                "use the image points stored in the view files instead of detecting them");
  cmd->add_option("--outlier-px", args->options.outlier_px, "reject points beyond this error (px)")
      ->capture_default_str();
  cmd->add_option("--flag-rms-px", args->options.flag_rms_px,
                  "flag cameras whose RMS exceeds this (px)")
      ->capture_default_str();
  cmd->add_option("--flag-max-px", args->options.flag_max_px,
                  "flag cameras whose largest error exceeds this (px)")
      ->capture_default_str();
  cmd->add_option("--min-floor-marks", args->options.min_stage2_points,
                  "floor marks each camera must see")
      ->capture_default_str();
  cmd->add_option("--threads", args->options.threads, "worker threads (0 = all)")
      ->capture_default_str();
  cmd->callback([=] {
    if (!args->points.empty()) {
      core::Require(args->take.empty(), "TAKE", "give a take or --points, not both");
      core::Require(args->size.size() == 2, "--size", "needs the image width and height (px)");
      core::Require(args->sensor.size() == 4, "--sensor",
                    "needs the sensor constants ncx nfx dx_mm dy_mm");
      calib::CameraPrior prior;
      prior.id = args->id;
      prior.width_px = args->size[0];
      prior.height_px = args->size[1];
      prior.sensor = {args->sensor[0], args->sensor[1], args->sensor[2], args->sensor[3]};
      const calib::PointCalibration r =
          calib::CalibrateFromPoints(prior, calib::ReadPointFile(args->points), args->points);
      std::fputs(r.Report().c_str(), stdout);
      if (!args->out.empty()) {
        geometry::Rig rig;
        rig.source = "points";
        rig.cameras.push_back({r.camera, {}});
        schema::WriteRig(rig, args->out);
      }
      *exit_code = 0;
      return;
    }
    core::Require(!args->take.empty(), "TAKE", "missing: give a take folder or --points FILE");
    const std::filesystem::path take(args->take);
    calib::CalibrateOptions options = args->options;
    options.joint_refinement = !args->no_joint;
    const geometry::Rig prior = schema::ReadRig(
        args->prior.empty() ? take / "rig.json" : std::filesystem::path(args->prior));
    const calib::CalibrationResult result = calib::CalibrateTake(take, prior, options);
    const std::filesystem::path report =
        args->report.empty() ? take / "calib" / "report.json" : std::filesystem::path(args->report);
    io::WriteFileAtomically(report, result.ReportJson());
    schema::WriteRig(result.rig,
                     args->out.empty() ? take / "rig.json" : std::filesystem::path(args->out));
    std::fputs(result.BriefReport().c_str(), stdout);
    bool flagged = false;
    for (const auto& c : result.cameras) flagged = flagged || c.flagged;
    *exit_code = flagged ? 2 : 0;
  });
}

}  // namespace dome::cli
