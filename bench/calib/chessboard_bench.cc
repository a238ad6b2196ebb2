// Acceptance measurement (issue 5): Tsai calibration of a real camera from chessboard
// corners, against OpenCV's calibrateCamera on the same corners (one radial
// coefficient, no tangential distortion).
//
//   build-calib/bin/calib_bench_chessboard [DATA_DIR]
// DATA_DIR defaults to ../shared/data/chessboards (left01..14.jpg, no 10; 9 x 6 inner
// corners; square size 1 unit, taken as 1 mm).
//
// Tsai: each view is initialised with the coplanar closed form (image centre at the
// middle, sx = 1, kappa1 = 0; its focal estimate; then all views re-initialised with
// the median focal length), then one Levenberg-Marquardt over f, kappa1, cx, cy, sx
// and every view's pose. Sensor constants: dx = dy = 0.01 mm, ncx = nfx = width.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/calib3d.hpp>
#include <string>
#include <vector>

#include "calib/detect.h"
#include "calib/tsai_calibration.h"
#include "core/error.h"
#include "io/image_io.h"

#ifndef DOME_SHARED_DIR
#define DOME_SHARED_DIR "../shared"
#endif

int main(int argc, char** argv) {
  namespace calib = dome::calib;
  const std::string dir = argc > 1 ? argv[1] : std::string(DOME_SHARED_DIR) + "/data/chessboards";
  try {
    calib::ChessboardOptions board;
    std::vector<std::vector<Eigen::Vector2d>> corners;
    std::vector<std::string> names;
    cv::Size size;
    for (int i = 1; i <= 14; ++i) {
      char name[32];
      std::snprintf(name, sizeof(name), "left%02d.jpg", i);
      const std::string path = dir + "/" + name;
      if (!std::filesystem::exists(path)) continue;
      const cv::Mat gray = dome::io::ReadImage(path, dome::io::ImageMode::kGray8);
      size = gray.size();
      std::vector<Eigen::Vector2d> c;
      if (!calib::DetectChessboard(gray, board, &c)) {
        std::printf("%s: board not found\n", name);
        continue;
      }
      corners.push_back(c);
      names.push_back(name);
    }
    std::printf("%zu images with all %d x %d corners found\n", corners.size(),
                board.inner_corners_x, board.inner_corners_y);
    if (corners.size() < 3) return 1;

    // OpenCV
    std::vector<std::vector<cv::Point3f>> object;
    std::vector<std::vector<cv::Point2f>> image;
    for (const auto& c : corners) {
      std::vector<cv::Point3f> o;
      std::vector<cv::Point2f> im;
      for (size_t k = 0; k < c.size(); ++k) {
        o.emplace_back(static_cast<float>(k % board.inner_corners_x),
                       static_cast<float>(k / board.inner_corners_x), 0.f);
        im.emplace_back(static_cast<float>(c[k].x()), static_cast<float>(c[k].y()));
      }
      object.push_back(o);
      image.push_back(im);
    }
    cv::Mat k_cv, dist_cv;
    std::vector<cv::Mat> rvecs, tvecs;
    const double rms_cv =
        cv::calibrateCamera(object, image, size, k_cv, dist_cv, rvecs, tvecs,
                            cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3 | cv::CALIB_ZERO_TANGENT_DIST);

    // Tsai
    dome::geometry::TsaiCamera cam;
    cam.id = "left";
    cam.width_px = size.width;
    cam.height_px = size.height;
    cam.sensor = {static_cast<double>(size.width), static_cast<double>(size.width), 0.01, 0.01};
    cam.cx_px = 0.5 * (size.width - 1);
    cam.cy_px = 0.5 * (size.height - 1);
    cam.sx = 1.0;
    cam.kappa1_per_mm2 = 0.0;
    std::vector<std::vector<calib::Correspondence>> pts;
    for (const auto& c : corners) {
      std::vector<calib::Correspondence> v;
      for (size_t k = 0; k < c.size(); ++k) {
        v.push_back({static_cast<int>(k),
                     Eigen::Vector3d(static_cast<double>(k % board.inner_corners_x),
                                     static_cast<double>(k / board.inner_corners_x), 0.0),
                     c[k]});
      }
      pts.push_back(v);
    }
    std::vector<double> focals;
    for (size_t v = 0; v < pts.size(); ++v) {
      focals.push_back(calib::TsaiInitCoplanar(cam, pts[v], false, {}, names[v]).focal_mm);
    }
    std::nth_element(focals.begin(), focals.begin() + focals.size() / 2, focals.end());
    cam.focal_mm = focals[focals.size() / 2];
    std::vector<calib::View> views;
    for (size_t v = 0; v < pts.size(); ++v) {
      const auto init = calib::TsaiInitCoplanar(cam, pts[v], true, {}, names[v]);
      views.push_back({names[v], pts[v], init.rotation, init.translation_mm});
    }
    calib::RefineOptions refine;
    refine.max_function_evaluations = 20000;
    const calib::RefineSummary s = calib::RefineCamera(&cam, &views, refine, dir);
    const Eigen::Matrix3d k = cam.K();

    std::printf("\n%-28s %12s %12s %10s\n", "", "Tsai (dome)", "OpenCV", "diff");
    std::printf("%-28s %12.4f %12.4f %9.1f%%\n", "RMS reprojection (px)", s.final_rms_px, rms_cv,
                100 * (s.final_rms_px / rms_cv - 1));
    const double fx_cv = k_cv.at<double>(0, 0), fy_cv = k_cv.at<double>(1, 1);
    const double cx_cv = k_cv.at<double>(0, 2), cy_cv = k_cv.at<double>(1, 2);
    std::printf("%-28s %12.2f %12.2f %9.2f%%\n", "fx (px)", k(0, 0), fx_cv,
                100 * (k(0, 0) / fx_cv - 1));
    std::printf("%-28s %12.2f %12.2f %9.2f%%\n", "fy (px)", k(1, 1), fy_cv,
                100 * (k(1, 1) / fy_cv - 1));
    std::printf("%-28s %12.2f %12.2f %9.2f%%\n", "cx (px)", k(0, 2), cx_cv,
                100 * (k(0, 2) - cx_cv) / cx_cv);
    std::printf("%-28s %12.2f %12.2f %9.2f%%\n", "cy (px)", k(1, 2), cy_cv,
                100 * (k(1, 2) - cy_cv) / cy_cv);
    std::printf("%-28s %12.4g %12.4g\n", "distortion", cam.kappa1_per_mm2, dist_cv.at<double>(0));
    std::printf(
        "  (Tsai kappa1 in 1/mm^2, distorted -> undistorted, dpx = 0.01 mm;\n"
        "   OpenCV k1 on normalised coordinates, undistorted -> distorted)\n");
    std::printf("Tsai sigma: f %.4g mm (%.3f%%), cx %.3f px, cy %.3f px, sx %.2e; %s\n",
                s.sigma.focal_mm, 100 * s.sigma.focal_mm / cam.focal_mm, s.sigma.cx_px,
                s.sigma.cy_px, s.sigma.sx, s.BriefReport().c_str());
    return 0;
  } catch (const dome::core::InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
