// TAKE/rig.json: the rig (geometry/rig.h) as the protobuf JSON of dome.proto.Rig
// (proto/rig.proto). Example:
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

#include "geometry/rig.h"

namespace dome::schema {

inline constexpr unsigned kRigFormatVersion = 1;

// Reads and checks (geometry::CheckRig) TAKE/rig.json. Throws core::InputError naming
// the file and field.
geometry::Rig ReadRig(const std::filesystem::path& path);
// Checks, then writes atomically (temporary file + rename). Throws core::InputError
// naming the file when it cannot be written.
void WriteRig(const geometry::Rig& rig, const std::filesystem::path& path);

// JSON text <-> rig, without touching the file system. `where` names the source in
// error messages.
geometry::Rig ParseRigJson(const std::string& json, const std::string& where);
std::string RigToJson(const geometry::Rig& rig);

}  // namespace dome::schema
