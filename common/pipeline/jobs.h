// The default pipeline's stages as runtime jobs (pipeline/stage.h DefaultStages), and
// the wire forms of their results. Per stage, its job's settings message and blobs:
//
//   stereo    StereoJob; blobs: rig, the reference frame, the neighbours' frames in
//             cluster order. Outputs: "stereo" (StereoOutput) and the range images'
//             files under OUT/<instant>/ (stereo/take_stereo.h EncodeStereoFiles).
//   fusion    FusionJob (planes [k0, k1), the resolved volume and fusion options);
//             blobs: rig, then every camera's "stereo" output in rig order.
//             Output: "slab" (fusion/volume.h EncodeSlab).
//   surface   the master's: the slabs stitched (pipeline/surface_stream.h) -> mesh.ply
//   decimate  DecimateJob; blob: mesh.ply. Output: mesh_decimated.ply.
//   texture   TextureJob; blobs: rig, mesh_decimated.ply, every camera's frame in rig
//             order. Outputs: mesh_decimated.ply (vertex colours) and, with the atlas,
//             textured.obj/.mtl/.png and textured.glb.
//   noop      nothing (dispatch benchmarks).
// Blob formats: rig = TAKE/rig.json text, frame = the take's PNG, mesh = binary PLY in
// world mm (EncodeMeshPly). Errors name the job and the blob at fault.
#pragma once

#include <string>
#include <vector>

#include "stereo/multi_baseline.h"
#include "stereo/take_stereo.h"

namespace dome::pipeline {

inline constexpr const char* kMaskOutput = "mask";  // a mask PNG, 255 = foreground
inline constexpr const char* kStereoOutput = "stereo";
inline constexpr const char* kSlabOutput = "slab";

// Stereo results <-> the "stereo" blob (runtime.StereoOutput). The blob carries each
// range image's maps as the rectangle of their non-zero values; DecodeStereoOutput gives
// the whole maps back (zeros around the rectangle).
std::string EncodeStereoOutput(const stereo::StereoResult& result);
stereo::StereoResult DecodeStereoOutput(const std::string& bytes, const std::string& where);
// The same without placing the maps in whole images of zeros (a Robovision map is 5 MB,
// its rectangle a fraction): the maps are the rectangles, and `cuts` (one per range
// image) says where they lie (a map that travelled whole: at 0, 0, its own size). Checks
// what DecodeStereoOutput checks.
stereo::StereoResult DecodeStereoRects(const std::string& bytes, const std::string& where,
                                       std::vector<stereo::MapCut>* cuts);

}  // namespace dome::pipeline
