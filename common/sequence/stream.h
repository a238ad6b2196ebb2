// The 4D file of `dome export` (default format, extension .dome4d): the whole sequence
// in one streamable file, every instant's mesh (sequence/mesh_codec.h) followed by its
// texture atlas as the next frame of one H.264 stream (sequence/video.h). A player
// reads it front to back and shows an instant as soon as its two records are in.
//
// File, little-endian:
//   8 bytes   "DOME4D\r\n"
//   u32 M     then M bytes of manifest, JSON (UTF-8):
//     {"format": "dome4d", "version": 1, "fps": F, "duration_s": D, "unit": "mm",
//      "world_to_gltf": [16 numbers, column-major, mesh/gltf.h],
//      "video": {"codec": "avc1.PPCCLL", "width": W, "height": H, "keyframe_every": K,
//                "colour": "bt601-limited"},
//      "mesh": {"codec": "draco-grid16", "origin_mm": [x, y, z], "step_mm": S},
//      "instants": [{"name": "HH-MM-SS-FF", "timecode": "HH:MM:SS:FF", "start_s": t,
//                    "triangles": T (as delivered)}, ...]}
//   records, for instant 0, 1, ...: its MESH record, then its TEXF record:
//     4 bytes tag ("MESH" or "TEXF"), u32 instant index, u32 payload length L,
//     u32 CRC-32 of the payload (zlib's, ISO 3309), L bytes payload.
// MESH payloads are EncodeMesh's (sequence/mesh_codec.h); TEXF payloads are one
// Annex B access unit (the frame of that instant). With keyframe_every 1 (the default)
// every instant decodes on its own, so a damaged or missing record costs that instant
// only.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/json.h"
#include "sequence/mesh_codec.h"
#include "sequence/sequence.h"
#include "sequence/video.h"

namespace dome::sequence {

inline constexpr char kStreamMagic[] = "DOME4D\r\n";

struct StreamOptions {
  VideoOptions video;
  // The position grid's step in mm; 0: an eighth of the session's voxel when it is
  // known (OUT/report.json), else the finest 16 bits give over the sequence's box.
  double step_mm = 0;
  void Check() const;
};

struct StreamSummary {
  int64_t bytes = 0, mesh_bytes = 0, video_bytes = 0;
  double step_mm = 0;
  int width = 0, height = 0;
  std::string codec;
};

std::string EncodeStream(const Sequence& sequence, const StreamOptions& options,
                         StreamSummary* summary);

struct StreamInstant {
  std::string name;
  std::string_view mesh, texture;  // payloads; empty when missing or damaged
  std::string broken;              // why, "" when both records are whole
};

struct ParsedStream {
  core::Json manifest;
  std::vector<StreamInstant> instants;  // one per manifest instant
};

// Splits a 4D file (possibly cut short) into its manifest and records. Throws
// core::InputError naming `where` when the header or manifest is unreadable; damaged
// or missing records mark their instant broken (StreamInstant::broken), never throw.
ParsedStream ParseStream(std::string_view bytes, const std::string& where);

// The reference decoder of a parsed stream: every whole instant's mesh with its atlas
// (the decoded video frame, texture coordinates over it). Broken instants are left
// out; their names and reasons go to *broken.
struct DecodedInstant {
  std::string name;
  mesh::TexturedMesh textured;
};
std::vector<DecodedInstant> DecodeStream(const ParsedStream& stream, const std::string& where,
                                         std::vector<std::string>* broken);

// How far a decoded stream is from the sequence it was made from.
struct StreamCheck {
  int decoded = 0;                  // instants decoded
  std::vector<std::string> broken;  // instants that did not decode, with the reason
  // The largest distance between a triangle corner as delivered and as in the source
  // mesh, mm: triangles and corners keep their order, so this bounds the Hausdorff
  // distance between the two surfaces.
  double max_displacement_mm = 0;
  // Source triangles not delivered: collapsed on the position grid (mesh_codec.h).
  int64_t collapsed_triangles = 0;
  // PSNR of the decoded atlas against the source atlas (over the atlas, BGR), dB.
  double min_psnr_db = 0, mean_psnr_db = 0;
};
StreamCheck CheckStream(const Sequence& sequence, std::string_view stream,
                        const std::string& where);

}  // namespace dome::sequence
