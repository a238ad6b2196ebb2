// A triangle mesh as a camera sees it, for scoring a reconstruction in a camera that did
// not take part in it: its silhouette (against the camera's mask, MaskIoU) and its
// colours (against the camera's image inside the mask, MaskedPsnr).
//
// Frames and units: mesh vertices in the world frame, mm (what dome writes); the camera
// is a geometry::TsaiCamera with its exact lens (Tsai's kappa1 or OpenCV's model,
// TsaiCamera::ProjectCamera). Images are the camera's own distorted pixel grid, pixel
// centres at integer coordinates (as the frames). Vertices are projected exactly;
// between them a triangle's edges are straight in the distorted image, which is what a
// lens does to a straight edge only to first order: a decimated mesh's triangles span
// a few tens of pixels, over which the lens's curvature is well under a pixel.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

#include "geometry/tsai_camera.h"
#include "io/mesh.h"

namespace dome::silhouette {

// Per pixel, the nearest triangle whose projection covers the pixel's centre.
struct MeshRendering {
  cv::Mat face;     // CV_32SC1: face index into the mesh, -1 where none
  cv::Mat depth;    // CV_32FC1: camera z of that surface point, mm; +inf where none
  cv::Mat weights;  // CV_32FC3: the point's barycentric weights of the face's corners
                    // 0, 1, 2 (perspective-correct: of the 3D triangle, not of its image)
};

// Renders `mesh` (triangles; a point cloud renders nothing) into `camera`'s image.
// Triangles with a corner at or behind the camera's plane (z <= 0) are left out; the
// depth test keeps the nearest surface. A pixel centre on an edge shared by two
// triangles belongs to the nearer (to either at equal depth).
MeshRendering RenderMesh(const geometry::TsaiCamera& camera, const io::Mesh& mesh);

// 255 where the rendering has a surface, 0 elsewhere (CV_8UC1).
cv::Mat RenderedMask(const MeshRendering& rendering);

// The rendering coloured by the mesh's per-vertex colours (RGB in the mesh, BGR out),
// interpolated with the weights; black where no surface (CV_8UC3). Throws
// core::InputError when the mesh has no colours.
cv::Mat ShadeVertexColours(const MeshRendering& rendering, const io::Mesh& mesh);

// The rendering coloured from a texture atlas: `uv` holds 3 coordinates per face (OBJ
// convention: u right, v up, [0, 1] over the atlas), `atlas` is BGR (CV_8UC3); bilinear
// sampling at the texel position (u W - 0.5, (1 - v) H - 0.5). Black where no surface.
cv::Mat ShadeAtlas(const MeshRendering& rendering, const std::vector<Eigen::Vector2f>& uv,
                   const cv::Mat& atlas);

// Peak signal-to-noise ratio of `a` against `b` (8-bit, same size and channels) over
// the pixels where `mask` is nonzero: 10 log10(255^2 / MSE), the MSE over those pixels
// and all channels, dB. +inf when they are equal there; NaN when the mask is empty.
double MaskedPsnr(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask);

// Connected components of the mesh's triangles (two triangles connect when they share
// a vertex); vertices in no triangle are not counted.
int MeshComponents(const io::Mesh& mesh);

}  // namespace dome::silhouette
