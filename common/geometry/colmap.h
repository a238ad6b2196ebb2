// COLMAP text models (cameras.txt, images.txt; colmap.github.io/format.html) <->
// TsaiCamera.
//
// cameras.txt — one line per camera, '#' lines are comments:
//   CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]
// Models read and what they mean (normalized undistorted x_u = Xc / Zc):
//   SIMPLE_PINHOLE  f cx cy                     fx = fy = f, no distortion
//   PINHOLE         fx fy cx cy                 no distortion
//   SIMPLE_RADIAL   f cx cy k                   x_d = x_u (1 + k r^2)
//   RADIAL          f cx cy k1 k2               x_d = x_u (1 + k1 r^2 + k2 r^4)
//   OPENCV          fx fy cx cy k1 k2 p1 p2     read only with p1 = p2 = 0 (Tsai has no
//                                               tangential term); written when fx != fy
//   pixel = (fx x_d + cx, fy y_d + cy)          other models are rejected by name.
// images.txt — two lines per image, '#' lines before an image line are comments:
//   IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME
//   POINTS2D[] as (X Y POINT3D_ID) triples      (may be empty; validated, not kept)
// (QW, QX, QY, QZ) is the unit Hamilton quaternion of R and (TX, TY, TZ) = t of the
// world -> camera pose camera = R * world + t, in model units. points3D.txt is neither
// read nor needed; the writer writes it with no points.
//
// Pixel convention: COLMAP puts the centre of the top-left pixel at (0.5, 0.5); dome
// (and Tsai, OpenCV, HALCON) at (0, 0). So cx_dome = cx_colmap - 0.5 and likewise cy;
// the writer adds the 0.5 back. Exact.
//
// Units: a COLMAP reconstruction has an arbitrary scale. The reader multiplies
// translations by options.mm_per_unit (required; e.g. the size in mm of one model unit
// found from a known distance); the writer divides by it.
//
// What is exact and what is approximate (pinhole.h): K, R, t and the 0.5 px shift are
// exact. Without distortion (SIMPLE_PINHOLE, PINHOLE, or k = 0) the cameras are exact.
// SIMPLE_RADIAL / RADIAL / OPENCV distort forward, Tsai backward: kappa1 is fitted over
// the whole image (k2 included in the fit) and each image carries the RadialFitReport
// (max / rms residual in pixels) of its camera. Writing a camera with kappa1 != 0 fits
// k (and k2 with fit_k2) the other way and returns the reports.
// Quaternions must have norm 1 to 1e-3 (then are normalized): COLMAP writes 17 digits,
// hand-made files fewer.
#pragma once

#include <string>
#include <vector>

#include "geometry/pinhole.h"
#include "geometry/tsai_camera.h"

namespace dome::geometry {

struct ColmapReadOptions {
  double mm_per_unit = 0.0;          // millimetres per model unit (required, > 0)
  PinholeConversionOptions pinhole;  // sensor constants and fit grid for Tsai

  // InputError naming the option ("ColmapReadOptions.mm_per_unit") when out of range.
  void Check() const;
};

struct ColmapImage {
  int image_id = 0;
  int camera_id = 0;
  std::string name;                // image file name, relative to COLMAP's image folder
  int num_points2d = 0;            // observations on the image's second line
  TsaiCamera camera;               // id = name; millimetres; dome pixel convention
  RadialFitReport distortion_fit;  // how well kappa1 reproduces the COLMAP distortion
};

// Reads <folder>/cameras.txt and <folder>/images.txt. Images in file order.
// InputError naming the file, line and field ("images.txt: line 7: QW") for a missing
// file, malformed or non-numeric field, unknown or unsupported camera model, wrong
// parameter count, non-unit quaternion, repeated ids, or an image whose CAMERA_ID is not
// in cameras.txt.
std::vector<ColmapImage> ReadColmapModel(const std::string& folder,
                                         const ColmapReadOptions& options);
// The same with explicit file paths.
std::vector<ColmapImage> ReadColmapModelFiles(const std::string& cameras_path,
                                              const std::string& images_path,
                                              const ColmapReadOptions& options);

struct ColmapWriteOptions {
  double mm_per_unit = 1.0;          // millimetres per model unit written (> 0)
  PinholeConversionOptions pinhole;  // fit grid; fit_k2 writes RADIAL instead of
                                     // SIMPLE_RADIAL (OPENCV's k2 otherwise 0)
  void Check() const;
};

// Writes <folder>/cameras.txt, images.txt and an empty points3D.txt: one COLMAP camera
// and one image per TsaiCamera, ids 1..N in order, NAME = camera.id (non-empty, no
// white space). Model: PINHOLE when kappa1 = 0; else SIMPLE_RADIAL (RADIAL with
// fit_k2) when fx = fy, else OPENCV with p1 = p2 = 0. Returns the distortion-fit report
// of each camera (exact when kappa1 = 0). InputError naming the file and camera when a
// camera fails Check, the name is unusable or the folder is not writable.
std::vector<RadialFitReport> WriteColmapModel(const std::string& folder,
                                              const std::vector<TsaiCamera>& cameras,
                                              const ColmapWriteOptions& options);

}  // namespace dome::geometry
