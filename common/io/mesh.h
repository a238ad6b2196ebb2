// The in-memory triangle mesh / point cloud shared by readers, writers and stages.
//
// Units are those of the file or producer: dome itself writes millimetres in the
// world frame; the Robovision reference clouds are in metres. Consumers that care
// (eval) take the scale to millimetres as an explicit option.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace dome::io {

using Color3u8 = Eigen::Matrix<uint8_t, 3, 1>;

struct Mesh {
  // Vertex positions.
  std::vector<Eigen::Vector3f> vertices;
  // Per-vertex normals (not necessarily unit length as read); empty = none.
  std::vector<Eigen::Vector3f> normals;
  // Per-vertex colours, R G B in 0..255; empty = none.
  std::vector<Color3u8> colors;
  // Per-vertex alpha in 0..255; empty = none. Only meaningful with colors.
  std::vector<uint8_t> alphas;
  // Triangles as vertex indices, counter-clockwise seen from outside; empty = a point
  // cloud.
  std::vector<Eigen::Vector3i> faces;

  bool HasNormals() const { return !normals.empty(); }
  bool HasColors() const { return !colors.empty(); }
  bool HasAlphas() const { return !alphas.empty(); }
  bool HasFaces() const { return !faces.empty(); }

  // Empty when the attribute arrays are either empty or one per vertex and every face
  // index is in range; otherwise a description of the first problem found.
  std::string Inconsistency() const;
};

}  // namespace dome::io
