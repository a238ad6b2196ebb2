// The rig of a take: every camera's Tsai model and optional stereo cluster.
//
// File: TAKE/rig.json, protobuf JSON of dome.proto.Rig (proto/rig.proto). Example:
//   {"format_version": 1, "source": "synthetic", "source_unit": "mm", "source_unit_mm": 1,
//    "cameras": [{"id": "c00", "width_px": 320, "height_px": 245,
//                 "sensor": {"ncx": 320, "nfx": 320, "dx_mm": 0.01, "dy_mm": 0.01},
//                 "focal_mm": 1.6, "kappa1_per_mm2": 0.02, "cx_px": 160, "cy_px": 122,
//                 "sx": 1.0, "rotation": [9 values, row-major, world -> camera],
//                 "translation_mm": [3 values], "neighbours": ["c01", "c02"]}]}
// Unknown fields are rejected; every error names the file and the field.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "geometry/tsai_camera.h"

namespace dome::take {

inline constexpr unsigned kRigFormatVersion = 1;

struct RigCamera {
  geometry::TsaiCamera model;
  std::vector<std::string> neighbours;  // stereo cluster; empty = derive from geometry
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
// non-empty ids, every camera valid (TsaiCamera::Check), neighbours naming known
// cameras other than itself, a positive finite source_unit_mm. Throws
// core::InputError naming `where` (usually the file) and the field, e.g.
// "rig.json: cameras[3] (id 'c03').focal_mm: must be positive, got -2".
void CheckRig(const Rig& rig, const std::string& where);

// Reads and checks TAKE/rig.json. Throws core::InputError naming the file and field.
Rig ReadRig(const std::filesystem::path& path);
// Checks, then writes atomically (temporary file + rename). Throws core::InputError
// naming the file when it cannot be written.
void WriteRig(const Rig& rig, const std::filesystem::path& path);

// JSON text <-> rig, without touching the file system. `where` names the source in
// error messages.
Rig ParseRigJson(const std::string& json, const std::string& where);
std::string RigToJson(const Rig& rig);

}  // namespace dome::take
