// A preview image of a mesh seen from one rig camera, ray cast with Embree 3 (Debian
// libembree-dev): one ray per pixel centre through the camera's Tsai model (distortion
// included, geometry/tsai_camera.h), so the preview lines up pixel for pixel with
// that camera's frame.
//
// Shading: the per-vertex colours interpolated at the hit when the mesh has them
// (texture from the images, mesh/texture.h) and `use_colors`; otherwise grey by the
// cosine between the surface normal and the ray (a light at the camera):
// 40 + 215 |cos|. Pixels whose ray misses the mesh are black.
#pragma once

#include <opencv2/core.hpp>

#include "geometry/tsai_camera.h"
#include "io/mesh.h"

namespace dome::mesh {

struct PreviewOptions {
  bool use_colors = true;  // shade with the vertex colours when present
  int num_threads = 0;     // threads over image rows; <= 0: all hardware threads
};

// CV_8UC3 BGR image of camera.width_px x camera.height_px. Throws core::InputError
// naming the mesh or camera when either is invalid.
cv::Mat RenderPreview(const io::Mesh& mesh, const geometry::TsaiCamera& camera,
                      const PreviewOptions& options = {});

// Per-pixel z-depth (camera z, mm, 0 = no hit) of the mesh from the camera, by the same
// rays: the mesh reprojected into that camera (CV_32FC1).
cv::Mat RenderDepth(const io::Mesh& mesh, const geometry::TsaiCamera& camera, int num_threads = 0);

}  // namespace dome::mesh
