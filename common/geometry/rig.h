// A camera rig: every camera's Tsai model (geometry/tsai_camera.h: world -> camera
// poses, mm and pixels) and its optional stereo cluster, and the length unit of the
// source the calibration came from. On disk it is TAKE/rig.json (schema/rig_json.h).
#pragma once

#include <string>
#include <vector>

#include "geometry/tsai_camera.h"

namespace dome::geometry {

struct RigCamera {
  TsaiCamera model;
  std::vector<std::string> neighbours;  // stereo cluster (camera ids); empty = from geometry
};

struct Rig {
  std::vector<RigCamera> cameras;
  std::string source = "unknown";  // where the calibration came from
  std::string source_unit = "mm";  // length unit of the source data
  double source_unit_mm = 1.0;     // millimetres per source unit

  // Index of the camera with this id, or -1.
  int Find(const std::string& id) const;
};

// Checks what a rig must satisfy whatever the take: at least one camera, unique
// non-empty ids that can name files, every camera valid (TsaiCamera::Check), neighbours
// naming known cameras other than itself, a positive finite source_unit_mm. Throws
// core::InputError naming `where` (usually the file) and the field, e.g.
// "rig.json: cameras[3] (id 'c03').focal_mm: must be positive, got -2".
void CheckRig(const Rig& rig, const std::string& where);

// "<where>: cameras[i] (id '<id>')": how errors name one camera of a rig.
std::string RigCameraWhere(const std::string& where, size_t i, const std::string& id);

}  // namespace dome::geometry
