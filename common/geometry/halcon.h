// HALCON 12 camera files (as published with the Robovision multi-view stereo data set,
// github.com/drewm1980/multi_view_stereo_benchmark_data) <-> TsaiCamera.
//
// Intrinsics: HALCON 12 "internal camera parameters" file (write_cam_par). Lines
// starting with '#' are comments; each parameter is an entry
//
//   Focus:foc:	0.0177071077277789;
//   	DOUBLE:0.0:;
//   	"Focal length of the lens";
//
// i.e. "Name:shortname:<value>;" followed by a type line and a description line (both
// ignored). Parameters read (area-scan camera, polynomial or division model):
//   Focus        focal length, metres (0 would mean a telecentric lens: rejected)
//   Poly1..Poly5 polynomial distortion (area_scan_polynomial). Must all be 0: HALCON's
//                polynomial model (radial K1..K3 on *distorted* coordinates in metres
//                plus tangential terms) is not Tsai's one-term kappa1, and the data
//                this reader serves is already undistorted.
//   Kappa        division-model distortion (area_scan_division), instead of Poly1..5.
//                Must be 0 for the same reason.
//   Sx, Sy       sensor cell width and height, metres
//   Cx, Cy       principal point (column, row), pixels. HALCON's pixel coordinates
//                have the centre of the top-left pixel at (0, 0), like dome's.
//   ImageWidth, ImageHeight   pixels (integers)
// HALCON projects u = Focus Xc / Zc, v = Focus Yc / Zc (metres, camera frame), then
// column = u / Sx + Cx, row = v / Sy + Cy. The mapping to Tsai (millimetres) is exact:
//   focal_mm = 1000 Focus, dx_mm = 1000 Sx, dy_mm = 1000 Sy, ncx = nfx = ImageWidth
//   (so dpx = dx), sx = 1, cx_px = Cx, cy_px = Cy, kappa1 = 0.
// Writing folds sx into the cell width (Sx = dpx / sx / 1000), so a camera with sx != 1
// or ncx != nfx reads back with the same K and pixel mapping but sx = 1, dx = dpx / sx.
//
// Extrinsics: the data set's own text file, not a HALCON pose file: 12 numbers
// separated by white space, a row-major 3x4 matrix [R | t], t in metres, optionally
// followed by '#' and anything after it (a comment). The pose maps CAMERA -> WORLD:
//   world = R * camera + t     (t is the camera centre in world coordinates).
// Established on the real data (tests/geometry/halcon_test.cc): read this way, 100% of
// the reference.ply points of all 4 scenes project in front of all 12 cameras, inside
// the image and onto valid (alpha = 255) pixels, and the image gray level at the
// projections correlates with the points' own colours (r = 0.24..0.61); read as
// world -> camera, the points fall behind 11 of the 12 cameras, and the one camera
// whose R is nearly its own inverse (camera07) shows correlation <= 0.14.
// The rotation is printed with 6 decimals (|R R^T - I| up to 1.0e-6 in the data), so
// the reader accepts an orthonormality error up to 1e-5 and then projects R onto the
// nearest rotation.
#pragma once

#include <string>

#include "geometry/tsai_camera.h"

namespace dome::geometry {

// Intrinsics only (pose = identity). id becomes the camera's id. InputError naming the
// file and parameter ("intrinsics_camera01.txt: Sx") for a missing file, missing or
// repeated parameter, non-number, non-positive Focus / Sx / Sy / size, or a non-zero
// Poly1..5 / Kappa.
TsaiCamera ReadHalconIntrinsics(const std::string& path, const std::string& id);

// Reads the 12-number camera -> world pose and returns it as Tsai's world -> camera
// rotation and translation (mm): R_wc = R^T, t_wc = -1000 R^T t.
void ReadHalconExtrinsics(const std::string& path, Eigen::Matrix3d* rotation_world_to_camera,
                          Eigen::Vector3d* translation_world_to_camera_mm);

// Both files: the camera in millimetres, world -> camera, kappa1 = 0.
TsaiCamera ReadHalconCamera(const std::string& intrinsics_path, const std::string& extrinsics_path,
                            const std::string& id);

// Writers. The camera must pass Check and have kappa1 = 0 (HALCON's distortion models
// differ from Tsai's); InputError naming the file otherwise.
void WriteHalconIntrinsics(const std::string& path, const TsaiCamera& camera);
void WriteHalconExtrinsics(const std::string& path, const TsaiCamera& camera);

}  // namespace dome::geometry
