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
#pragma once

#include <filesystem>
#include <string>

#include "io/mesh.h"
#include "mesh/texture.h"

namespace dome::mesh {

std::string EncodeGlb(const TexturedMesh& textured);
std::string EncodeGlb(const io::Mesh& mesh);

// Atomic writes (io/file_util.h); core::InputError naming the file on failure.
void WriteGlb(const std::filesystem::path& path, const TexturedMesh& textured);
void WriteGlb(const std::filesystem::path& path, const io::Mesh& mesh);

}  // namespace dome::mesh
