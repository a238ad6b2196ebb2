// Cameras as OpenCV describes them, turned into dome's camera model.
//
// OpenCV's convention (calib3d): x_cam = R X + t (world -> camera, in the source's
// unit), then the distortion D of the normalized point (x/z, y/z), then
// K = [fx s cx; 0 fy cy; 0 0 1], pixel centres at integer coordinates as in dome.
// D has 4 (k1 k2 p1 p2), 5 (+ k3), 8 (+ k4 k5 k6, rational), 12 (+ s1..s4, thin
// prism) or 14 (+ tau_x tau_y, tilt) coefficients. dome holds k1 k2 p1 p2 k3 exactly
// (geometry/tsai_camera.h OpenCvLens); any other non-zero coefficient is refused with
// the largest image error, in pixels, that dropping it would make.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "geometry/tsai_camera.h"

namespace dome::geometry {

struct OpenCvCamera {
  std::string id;
  int width_px = 0;
  int height_px = 0;
  Eigen::Matrix3d k = Eigen::Matrix3d::Identity();  // intrinsics, px
  std::vector<double> distortion;                   // D: 0, 4, 5, 8, 12 or 14 numbers
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();  // world -> camera rotation
  Eigen::Vector3d t_mm = Eigen::Vector3d::Zero();   // world -> camera translation, mm
};

// The camera in dome's model: Tsai's sensor as one element per pixel of 0.01 mm
// (only focal length over pitch matters, as geometry/pinhole.h), fx / fy as sx, the
// lens as OpenCvLens. Throws core::InputError naming `where` (and the field) for a
// skewed or non-upper-triangular K, non-positive focal lengths or image size, a
// distortion of another length, coefficients dome cannot hold (with the error in
// pixels), and (TsaiCamera::Check) a rotation that is not one.
TsaiCamera CameraFromOpenCv(const OpenCvCamera& source, const std::string& where);

}  // namespace dome::geometry
