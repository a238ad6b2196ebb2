// Tsai's two-stage calibration of a take's cameras (seed §2.2, SPEC pipeline step 2):
//
//  Stage 1 (intrinsics): each camera's images of the 3D calibration object
//    (TAKE/calib/stage1/<camera>.json + image, target in the object frame, and the
//    object moved to further poses: <camera>.1.json, <camera>.2.json, ...): points
//    detected (calib/detect.h), Tsai's non-coplanar closed form with the image centre
//    at the middle of the image, then Levenberg-Marquardt over f, kappa1, cx, cy, sx
//    and the object's pose; then over the intrinsics and every view's pose.
//  Stage 2 (pose): the camera's image of the floor marks (calib/stage2/, world frame,
//    z = 0), intrinsics fixed: Tsai's coplanar closed form from the key-marked grid,
//    then LM over the pose; then the target's plain marks (calib/target.h), each
//    camera those it sees, predicted from that pose, found among the image's dots and
//    added, and the pose refitted. The floor marks put every camera into one world
//    frame.
//  Joint (optional): LM over the intrinsics and both poses with both stages' points.
//
// After each refinement, points whose reprojection error exceeds the outlier bound are
// rejected (and listed in the report), and the stage is refined again.
//
// Known parameters: a Tsai calibration needs each camera's sensor constants (ncx,
// nfx, dx, dy) and image size; they come from the prior rig (TAKE/rig.json, or another
// rig file), whose calibrated parameters are not used. Its neighbour lists are kept.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "calib/detect.h"
#include "calib/tsai_calibration.h"
#include "geometry/rig.h"

namespace dome::calib {

struct CalibrateOptions {
  DotDetectorOptions detector;
  TsaiInitOptions init;
  int max_function_evaluations = 4000;  // per LM run
  bool joint_refinement = true;         // the final joint refinement
  bool use_stored_points = false;       // use the views' stored points instead of detecting
  int max_stage1_views = 0;             // stage-1 images used per camera, 0 = all
  // Fit the images of the dot centres, not the dots' centroids (which perspective and
  // distortion shift, calib/tsai_calibration.h); detected dots only.
  bool correct_dot_centroids = true;
  int min_stage2_points = 6;  // floor marks a camera must see (Tsai: >= 5)
  // Plain floor marks (calib/target.h) whose dot images are narrower than this, px, are
  // not used: the far marks of a grazing view, whose centroids a few pixels of blob
  // cannot place to a tenth of a pixel.
  double min_plain_mark_px = 2.0;
  double outlier_px = 1.0;   // reject points beyond max(this, 4 x RMS), px
  double flag_rms_px = 0.3;  // flag cameras whose RMS exceeds this, px
  double flag_max_px = 1.0;  // flag cameras whose largest error exceeds this, px
  int worst_points = 5;      // per camera, in the report
  int threads = 0;           // 0 = all hardware threads
  // A camera that cannot be calibrated (its error) is flagged and keeps its prior
  // parameters instead of failing the whole take.
  bool keep_going = false;
  void Check() const;  // throws core::InputError naming the option
};

struct PointError {
  std::string stage;  // "stage1" or "stage2"
  int id = 0;
  double error_px = 0.0;
};

struct StageReport {
  int views = 1;                           // images used (stage 1: the object's poses)
  int points = 0;                          // used in the final fit, over the views
  int detected = 0;                        // identified in the image
  int blobs = 0;                           // dark blobs in the image
  std::vector<int> missing_ids;            // target points not found in the image
  std::vector<int> rejected_ids;           // found, rejected as outliers
  std::vector<std::string> skipped_views;  // further stage-1 views left out, and why
  double rms_px = 0.0;
  double max_px = 0.0;
  RefineSummary refine;
};

struct CameraReport {
  std::string id;
  StageReport stage1, stage2;
  double rms_px = 0.0;  // over both stages' points, final parameters
  double max_px = 0.0;
  std::vector<PointError> worst;  // largest errors first
  ParameterSigma sigma;  // intrinsics from stage 1 (or joint), pose from stage 2 (or joint)
  bool flagged = false;
  bool failed = false;  // keep_going: calibration failed, prior parameters kept
  std::string flag_reason;
};

struct CalibrationResult {
  geometry::Rig rig;
  std::vector<CameraReport> cameras;
  double seconds = 0.0;
  std::string BriefReport() const;  // human-readable, one line per camera
  std::string ReportJson() const;   // the report file (see WriteCalibrationReport)
};

// Calibrates every camera of the prior rig from TAKE/calib/. Throws core::InputError
// naming the file and what is wrong: a missing view or image, a target with NaN or
// duplicate ids, too few points, stage-1 points without volume, points behind the
// camera, a camera that sees too few floor marks.
CalibrationResult CalibrateTake(const std::filesystem::path& take_dir, const geometry::Rig& prior,
                                const CalibrateOptions& options);

// One camera, from its stage-1 views (the first required, the object's further poses
// optional) and its stage-2 view (what CalibrateTake runs per camera).
CameraReport CalibrateCamera(const geometry::RigCamera& prior,
                             const std::vector<std::filesystem::path>& stage1_views,
                             const std::filesystem::path& stage2_view,
                             const CalibrateOptions& options, geometry::TsaiCamera* calibrated);
// One stage-1 view.
CameraReport CalibrateCamera(const geometry::RigCamera& prior,
                             const std::filesystem::path& stage1_view,
                             const std::filesystem::path& stage2_view,
                             const CalibrateOptions& options, geometry::TsaiCamera* calibrated);

// A camera's view files in a stage folder: <camera>.json, then <camera>.<k>.json for
// k = 1, 2, ... as long as they exist (stage 1: the object moved to further poses).
std::vector<std::filesystem::path> ViewPaths(const std::filesystem::path& stage_dir,
                                             const std::string& camera);

}  // namespace dome::calib
