// Files the viewer computes from the outputs rather than serving them as they are.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "io/mesh.h"
#include "view/output_index.h"

namespace dome::view {

// For every vertex of `mesh`, its distance to the surface of `reference` (exact
// point-to-triangle distance through eval/triangle_bvh.h), in the meshes' unit (mm).
// A reference without triangles gives +infinity everywhere.
std::vector<float> VertexDistances(const io::Mesh& mesh, const io::Mesh& reference,
                                   int num_threads = 0);

// `values` as little-endian IEEE float32, 4 bytes each, in order.
std::string EncodeFloat32Le(const std::vector<float>& values);

// The per-vertex distances (mm) of an instant's mesh to its truth mesh, encoded as
// above, in the vertex order of the mesh's PLY. Throws core::InputError naming the
// file when either PLY is missing or malformed, or the instant has no truth mesh.
std::string VertexErrorFile(const ViewerIndex& index, int instant, MeshVariant variant);

// A colour-mapped PNG of camera `camera`'s depth map at `instant` (io DepthPreview:
// near = red, far = blue, no depth = black). Throws core::InputError naming the file
// when the depth map is missing or malformed.
std::string DepthPreviewFile(const ViewerIndex& index, int instant, int camera);

// A PNG of camera `camera`'s image at `instant` darkened outside its foreground mask,
// with the mask's outline (silhouette::MaskPreview; the mask from silhouette::TakeMasks
// with default options, as `dome masks` writes it). Throws core::InputError naming the
// camera when it has no mask, or the file that cannot be read.
std::string MaskPreviewFile(const ViewerIndex& index, int instant, int camera);

}  // namespace dome::view
