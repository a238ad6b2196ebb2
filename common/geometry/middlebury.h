// Middlebury multi-view stereo camera files (`*_par.txt`, Seitz et al., CVPR 2006,
// vision.middlebury.edu/mview) <-> TsaiCamera.
//
// Format (text, white-space separated):
//   line 1:        number of images N
//   N lines:       imgname k11 k12 k13 k21 k22 k23 k31 k32 k33
//                          r11 r12 r13 r21 r22 r23 r31 r32 r33 t1 t2 t3
// The projection of world point X is x ~ K (R X + t): R, t map world -> camera, t in
// metres (the data sets' unit), K in pixels with the image origin at the top left, x
// right, y down. The files do not say whether (0, 0) is the top-left pixel's centre or
// corner; we take it as the centre (dome's and OpenCV's convention) — the difference is
// half a pixel and no Middlebury data available to us can tell them apart.
// The files do not store the image size either: the caller passes it (for the temple
// and dino sets, 640x480).
//
// Mapping (pinhole.h): exact. K must be [fx 0 cx; 0 fy cy; 0 0 1] (zero skew); the
// Tsai cameras get the sensor constants of TsaiFromPinhole (options.pinhole) and
// kappa1 = 0 (the Middlebury images are distortion-free). Translations are scaled by
// options.mm_per_unit (1000: metres -> mm). The rotations, printed with ~17 digits, must
// be orthonormal to 1e-6 and are projected onto the nearest rotation.
#pragma once

#include <string>
#include <vector>

#include "geometry/pinhole.h"
#include "geometry/tsai_camera.h"

namespace dome::geometry {

struct MiddleburyReadOptions {
  int width_px = 0;                  // image width, in pixels (not in the file; required)
  int height_px = 0;                 // image height, in pixels (not in the file; required)
  double mm_per_unit = 1000.0;       // millimetres per file unit (the files use metres)
  PinholeConversionOptions pinhole;  // sensor constants chosen for the Tsai cameras

  // InputError naming the option ("MiddleburyReadOptions.width_px") when out of range.
  void Check() const;
};

// One camera per image line, in file order, id = the image name ("templeSR0001.png").
// InputError naming the file, line and field ("templeSR_par.txt: line 3
// (templeSR0002.png): r21") for a missing file, bad count, missing or non-numeric
// field, skewed or malformed K, non-rotation R, or a repeated image name.
std::vector<TsaiCamera> ReadMiddleburyPar(const std::string& path,
                                          const MiddleburyReadOptions& options);

// Writes the cameras (id = image name: non-empty, no white space) with t in units of
// 1 / mm_per_unit mm. Every camera must pass Check and have kappa1 = 0 (the format has
// no distortion); InputError naming the file and camera otherwise.
void WriteMiddleburyPar(const std::string& path, const std::vector<TsaiCamera>& cameras,
                        double mm_per_unit = 1000.0);

}  // namespace dome::geometry
