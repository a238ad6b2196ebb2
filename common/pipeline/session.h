// A session (proto/runtime.proto Session): a take, an output folder and the options
// of every stage, resolved against the libraries' defaults.
//
// File: SESSION.json, the protobuf JSON of dome.runtime.Session, e.g.
//   {"take": "/data/take1", "out": "/data/out1", "instants": ["00-00-00-00"],
//    "stereo": {"window_sizes_px": [7]}, "volume": {"voxel_size_mm": 40},
//    "slab_planes": 16, "decimate_ratio": 0.1, "texture": true}
// Unknown fields are rejected naming the field; unset fields take the defaults below.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "fusion/integrate.h"
#include "fusion/volume.h"
#include "mesh/smooth.h"
#include "pipeline/coarse_to_fine.h"
#include "runtime.pb.h"
#include "stereo/options_json.h"
#include "stereo/take_stereo.h"
#include "take/take.h"

namespace dome::pipeline {

struct SessionOptions {
  stereo::TakeStereoOptions stereo;  // write_previews: preview PNGs beside the depth maps
  fusion::VolumeGrid grid;           // default: the seed's 6 m cube of 20 mm voxels
  fusion::FusionOptions fusion;      // truncation and clamp default to 3 voxels, mm
  int slab_planes = 16;              // voxel planes per fusion job (count)
  double decimate_ratio = 0.1;       // fraction of triangles kept, (0, 1]; 1: not decimated
  bool texture = true;               // also write textured.obj/.mtl/.png
  mesh::SmoothOptions smooth;        // of the marching-cubes surface (mesh.ply); off

  // Throws core::InputError naming "session: <field>" for the first bad option.
  void Check() const;
};

// Reads SESSION.json; errors name the file and the field.
runtime::Session ReadSessionJson(const std::filesystem::path& path);

// The session's options with defaults filled in and checked. `where` names the source
// in errors ("session", a file). Does not open the take.
SessionOptions ResolveSessionOptions(const runtime::Session& session, const std::string& where);

// The instants to reconstruct: the session's list (each checked against the take) or
// every instant of the take, in time order.
std::vector<std::string> SessionInstants(const runtime::Session& session, const take::Take& take);

// Protobuf forms of resolved options, as jobs carry them (every field set). The stereo
// ones are stereo::ToStereoSettings / FromStereoSettings (stereo/options_json.h).
runtime::Volume ToVolume(const fusion::VolumeGrid& grid);
fusion::VolumeGrid FromVolume(const runtime::Volume& volume, const std::string& where);
runtime::FusionSettings ToFusionSettings(const fusion::FusionOptions& options);
fusion::FusionOptions FromFusionSettings(const runtime::FusionSettings& settings,
                                         double voxel_size_mm, const std::string& where);

// The coarse-to-fine options of StereoSettings.coarse_to_fine, library defaults for
// unset fields, checked with the clip box. Errors name "<where>: coarse_to_fine.<field>".
CoarseToFineOptions FromCoarseToFineSettings(const runtime::CoarseToFineSettings& settings,
                                             const std::string& where);

// `options`' depth range (z along `camera`'s optical axis, mm) clipped to the nearest and
// farthest corner of the settings' clip box, each widened by clip_pad_mm; unchanged
// without a box. Throws core::InputError naming `where` and the camera when the
// clipped range is empty (the box is behind the camera or outside the range).
void ClipDepthRange(const runtime::CoarseToFineSettings& settings,
                    const geometry::TsaiCamera& camera, const std::string& where,
                    stereo::StereoOptions* options);

}  // namespace dome::pipeline
