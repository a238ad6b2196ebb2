// One instant's textured mesh as the 4D stream carries it (sequence/stream.h): positions
// on the sequence's integer grid, compressed with Draco's edgebreaker mesh coder
// (Debian's libdraco-dev; the page decodes with Draco's own WebAssembly decoder, npm
// draco3d). Chosen over meshoptimizer's codecs by measurement
// (bench/sequence/mesh_codec_bench.cc): 0.61x the bytes on the paper take, what the
// 4D file's bitrate turns on; decoding takes 1.8 ms an instant against 0.4 ms, which a
// 30-instants-a-second player can spend.
//
// Texture coordinates are not sent: the stream's atlas is laid out by mesh/texture.h's
// grid rule over the payload's own triangle order, so triangle f's corner k has
// GridAtlasLayout::CornerTexel(f, k). The coder reorders triangles and rotates their
// corners; EncodeMesh says how (EncodedMesh), and RelayAtlas moves every triangle's
// texels to where the rule puts them: for an atlas made by the same rule this moves
// texels (corners land on texel centres), for any other it resamples the source atlas
// bilinearly. Triangles that collapse on the grid (two corners on one grid point) are
// not sent: they are thinner than the grid step.
//
// Payload, little-endian:
//   f32 origin_mm[3], f32 step_mm     position = origin + q * step
//   u32 cell_px, u32 columns          the atlas grid (GridAtlasLayout), at the top-left of
//                                     the video frame
//   the rest                          a Draco mesh (edgebreaker) whose POSITION attribute
//                                     is q, 3 x uint16, no other attribute; nothing for
//                                     an instant without triangles
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mesh/texture.h"

namespace dome::sequence {

// The grid layout `textured` was made with when its texture coordinates and atlas are
// exactly (to float rounding) those of mesh/texture.h's rule; nullopt otherwise.
std::optional<mesh::GridAtlasLayout> GridLayoutOf(const mesh::TexturedMesh& textured);

struct QuantizedBox {
  Eigen::Vector3f origin_mm = Eigen::Vector3f::Zero();
  float step_mm = 1;  // the grid's edge; positions move by at most step/2 on each axis
};

// The 16-bit grid over `lo`..`hi` (mm) whose step is at most `max_step_mm` (or the
// finest 16 bits allow when that is smaller). The step is a power of two times a
// micrometre, so instants quantized on the same box keep static parts bit-identical.
QuantizedBox QuantizationFor(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi,
                             double max_step_mm);

struct EncodedMesh {
  std::string payload;
  // Triangle f of the payload is source triangle source_face[f]; its corner k is the
  // source's corner (k + rotation[f]) % 3.
  std::vector<int> source_face;
  std::vector<uint8_t> rotation;
  mesh::GridAtlasLayout layout;  // of the payload's triangles
};

// The payload of `mesh` (positions and triangles) with an atlas grid of `cell_px`
// texels. Throws core::InputError when a vertex lies outside the box's 16 bits.
EncodedMesh EncodeMesh(const io::Mesh& mesh, const QuantizedBox& box, int cell_px);

// The atlas of `encoded`'s triangles (encoded.layout's size) from `source`'s.
cv::Mat RelayAtlas(const mesh::TexturedMesh& source, const EncodedMesh& encoded);

struct DecodedMesh {
  io::Mesh mesh;
  mesh::GridAtlasLayout layout;
};

// The reference decoder (the page's stream player does the same). Throws core::InputError
// naming `where` when the payload is damaged.
DecodedMesh DecodeMeshPayload(std::string_view payload, const std::string& where);

// Texture coordinates (OBJ's convention, v up) of the grid rule for `faces` triangles
// whose atlas sits at the top-left of a frame_w x frame_h frame.
std::vector<Eigen::Vector2f> GridUv(const mesh::GridAtlasLayout& layout, int64_t faces,
                                    int frame_w, int frame_h);

}  // namespace dome::sequence
