// Binary glTF 2.0 (GLB) output of a mesh, one self-contained file per instant for the
// viewer (Khronos glTF 2.0 specification, "GLB File Format Specification").
//
// Layout: the 12-byte header ("glTF", version 2, total length), a JSON chunk and one
// BIN chunk (little-endian, each padded to 4 bytes). Vertex positions are dome's
// world frame in mm, exactly as in the PLY outputs; the single node carries the
// matrix that makes them glTF's metres with y up (x' = x, y' = z, z' = -y, times
// 0.001), so a viewer shows the dome upright and to scale.
//  * Textured (TexturedMesh, mesh/texture.h): every face gets its own three vertices
//    (the atlas gives each face its own texture coordinates), TEXCOORD_0 in glTF's
//    convention (v down: v_gltf = 1 - v_obj), the atlas embedded as PNG, an unlit-
//    looking material (metallic 0, roughness 1).
//  * Vertex-coloured (io::Mesh with colours): shared vertices, COLOR_0 as normalized
//    unsigned bytes RGBA; without colours, positions only.
//
// Reading (DecodeTexturedGlb) takes back what EncodeGlb(TexturedMesh) writes: one
// mesh of one triangle primitive with float POSITION and TEXCOORD_0, uint32 indices and
// an embedded PNG or JPEG base colour texture. Corners with bit-identical positions
// become one vertex again, so the mesh has the vertices it was written from.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include "core/json.h"
#include "io/mesh.h"
#include "mesh/texture.h"

namespace dome::mesh {

// A GLB under construction: the BIN chunk and the JSON of its buffer views and
// accessors. The document (scenes, nodes, meshes, materials, animations) is the caller's.
class GlbBuilder {
 public:
  // Appends `bytes` as a buffer view (4-byte aligned); returns its index. `target` is
  // the view's bufferView.target, 0 for none (an image, animation data).
  int AddView(const void* bytes, size_t size, int target);
  // An accessor over a whole view; min/max (an object with both) are required for
  // POSITION and animation inputs.
  int AddAccessor(int view, int component_type, size_t count, const char* type, bool normalized,
                  const core::Json& min_max = core::Json::object());
  // Appends the triangles of `textured` to `document` as one more mesh (its vertices,
  // texture coordinates, indices, and a material with the atlas as a PNG texture);
  // returns the mesh's index in document["meshes"].
  // `atlas_png`: the atlas already encoded as PNG (its pixels must be textured.atlas's);
  // null: encoded here (PngEncoding::kFast).
  int AddTexturedMesh(const TexturedMesh& textured, core::Json* document,
                      const std::string* atlas_png = nullptr);
  // The GLB container of `document` with the asset, buffers, views and accessors added.
  std::string Finish(const core::Json& document);

 private:
  std::string bin_;
  core::Json views_ = core::Json::array(), accessors_ = core::Json::array();
};

// glTF component types and buffer view targets.
inline constexpr int kGltfFloat = 5126, kGltfUnsignedInt = 5125, kGltfUnsignedByte = 5121;
inline constexpr int kGltfArrayBuffer = 34962, kGltfElementArrayBuffer = 34963;

// The node matrix (column-major 4x4) from dome's world frame in mm, z up, to glTF's
// metres, y up.
core::Json WorldToGltfMatrix();

// `atlas_png` as in GlbBuilder::AddTexturedMesh.
std::string EncodeGlb(const TexturedMesh& textured, const std::string* atlas_png = nullptr);
std::string EncodeGlb(const io::Mesh& mesh);

// Atomic writes (io/file_util.h); core::InputError naming the file on failure.
void WriteGlb(const std::filesystem::path& path, const TexturedMesh& textured);
void WriteGlb(const std::filesystem::path& path, const io::Mesh& mesh);

// The textured mesh of a GLB written by EncodeGlb(TexturedMesh). Throws
// core::InputError naming `where` and the part that is missing or malformed.
TexturedMesh DecodeTexturedGlb(std::string_view glb, const std::string& where);
TexturedMesh ReadTexturedGlb(const std::filesystem::path& path);

}  // namespace dome::mesh
