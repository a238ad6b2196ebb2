// The synthetic dome's cameras: the seed's 51 cameras on a 5 m geodesic dome (§4.1,
// Figure 7), each a Tsai camera (geometry/tsai_camera.h) with its own parameters, as
// digitized by the seed (§4.2).
//
// Geometry (world frame, mm, z up): camera centres are vertices of a geodesic sphere
// of radius 2.5 m centred on the dome's axis 250 mm above the floor -- an icosahedron
// with a vertex at the top, each face subdivided `frequency` times (class I) -- namely
// the N highest vertices (elevation >= 20 deg; for N = 51 at frequency 4, exactly the
// vertices down to the 26.6 deg ring). Each looks at a point near (0, 0, 900) (jittered
// by up to 60 mm per axis) with image "up" towards world +z (world +y for the cameras
// that look almost straight down) and a little roll. A camera's neighbours (rig.json
// `neighbours`, the seed's stereo clusters, §4.3) are the cameras joined to it by an
// edge of the geodesic sphere: 3-6 cameras (clusters of 4-7).
//
// Digitization (seed §4.2): the NTSC frame is 2W x 2H samples (640 x 490 for the paper
// preset) on a 6.4 mm x 4.8 mm sensor; interlaced, its even rows (0, 2, ...) are the
// first field and its odd rows the second, exposed 1/60 s later. The take's image is
// the first field with column pairs averaged: W x H (320 x 245). Tsai's sensor
// constants say exactly that: ncx = 2W sensor elements of dx = 6.4 / 2W mm per line,
// nfx = W pixels per digitized line, dy = 2 x 4.8 / 2H mm (a field skips every other
// line). So the rig camera maps a world point to the take image's pixel directly, and
// frame sample (column j, row r) sits at take-image coordinates ((j - 0.5) / 2, r / 2).
//
// Per camera, drawn from a fixed stream (never from the user's seed): focal length
// (+-3% around a 90 deg x ~74 deg field of view), kappa1 in [1, 2] x 1e-3 / mm^2 (barrel
// distortion, 3-6 px at the corners of a 320-wide image), image centre offset
// (sigma 3 px), sx = 1 +- 1%, gain, offset and noise level.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "geometry/rig.h"

namespace dome::synth {

// The camera's photometric response: value = gain * radiance + offset + noise, then
// rounded and clamped to 0..255 (synth/render.h).
struct CameraResponse {
  double gain = 190.0;       // grey levels per unit radiance
  double offset = 0.0;       // grey levels
  double noise_sigma = 2.0;  // grey levels, per frame sample
};

struct DomeCamera {
  geometry::RigCamera rig;  // model + neighbours, as written to rig.json
  CameraResponse response;
  double elevation_deg = 0.0;  // of the camera centre seen from the dome's centre
  double azimuth_deg = 0.0;
  int geodesic_vertex = 0;
};

struct DomeRigOptions {
  int cameras = 51;                 // number of cameras (the highest geodesic vertices)
  int width_px = 320;               // take image width (frame width / 2), in pixels
  int height_px = 245;              // take image height (lines of one field), in pixels
  double radius_mm = 2500.0;        // of the geodesic sphere
  double centre_height_mm = 250.0;  // of the sphere's centre above the floor
  Eigen::Vector3d aim_mm = Eigen::Vector3d(0, 0, 900);  // where cameras look
  double min_elevation_deg = 20.0;                      // lowest allowed camera elevation

  // Largest camera count the dome offers (frequency <= 8).
  static int MaxCameras();
  // Throws core::InputError naming the flag (--cameras, --width, --height) at fault.
  void Check() const;
};

// The dome's cameras, ordered by elevation (top first) then azimuth; ids "c00", "c01", ...
std::vector<DomeCamera> MakeDomeRig(const DomeRigOptions& options);

// Sensor constants of the digitized image (see the header comment).
geometry::TsaiSensor DigitizedSensor(int width_px, int height_px);

}  // namespace dome::synth
