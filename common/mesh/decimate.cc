#include "mesh/decimate.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/timer.h"

namespace dome::mesh {

void DecimationOptions::Check() const {
  core::Require(target_triangles >= 0, "decimation: target_triangles",
                "must be >= 0, got " + std::to_string(target_triangles));
  core::Require(std::isfinite(target_ratio) && target_ratio > 0.0 && target_ratio <= 1.0,
                "decimation: target_ratio",
                "must be in (0, 1], got " + std::to_string(target_ratio));
  core::Require(std::isfinite(max_error_mm) && max_error_mm >= 0.0, "decimation: max_error_mm",
                "must be >= 0 mm, got " + std::to_string(max_error_mm));
}

io::Mesh Decimate(const io::Mesh& mesh, const DecimationOptions& options,
                  DecimationSummary* summary) {
  options.Check();
  const std::string bad = mesh.Inconsistency();
  core::Require(bad.empty(), "decimation: mesh", bad);
  core::Stopwatch watch;
  const size_t triangles = mesh.faces.size();
  std::vector<unsigned int> indices(triangles * 3);
  for (size_t f = 0; f < triangles; ++f) {
    for (int m = 0; m < 3; ++m) indices[3 * f + m] = static_cast<unsigned int>(mesh.faces[f][m]);
  }
  const float* positions = mesh.vertices.empty() ? nullptr : mesh.vertices[0].data();
  const size_t target_triangles =
      options.target_triangles > 0 ? size_t(options.target_triangles)
                                   : size_t(std::llround(options.target_ratio * double(triangles)));
  float scale = 1.0f;
  if (!mesh.vertices.empty()) {
    scale = meshopt_simplifyScale(positions, mesh.vertices.size(), sizeof(Eigen::Vector3f));
  }
  const float target_error =
      options.max_error_mm > 0.0 && scale > 0.0f ? float(options.max_error_mm / scale) : 1e30f;
  std::vector<unsigned int> out(indices.size());
  float result_error = 0.0f;
  size_t n_out = 0;
  if (!indices.empty()) {
    n_out = meshopt_simplify(out.data(), indices.data(), indices.size(), positions,
                             mesh.vertices.size(), sizeof(Eigen::Vector3f), target_triangles * 3,
                             target_error, options.lock_border ? meshopt_SimplifyLockBorder : 0,
                             &result_error);
  }
  out.resize(n_out);
  io::Mesh result;
  std::vector<int> remap(mesh.vertices.size(), -1);
  for (size_t f = 0; f + 2 < out.size(); f += 3) {
    Eigen::Vector3i face;
    for (int m = 0; m < 3; ++m) {
      const unsigned int v = out[f + m];
      if (remap[v] < 0) {
        remap[v] = static_cast<int>(result.vertices.size());
        result.vertices.push_back(mesh.vertices[v]);
        if (mesh.HasNormals()) result.normals.push_back(mesh.normals[v]);
        if (mesh.HasColors()) result.colors.push_back(mesh.colors[v]);
        if (mesh.HasAlphas()) result.alphas.push_back(mesh.alphas[v]);
      }
      face[m] = remap[v];
    }
    result.faces.push_back(face);
  }
  if (summary) {
    summary->triangles_in = int64_t(triangles);
    summary->triangles_out = int64_t(result.faces.size());
    summary->error_mm = double(result_error) * scale;
    summary->seconds = watch.ElapsedSeconds();
  }
  return result;
}

}  // namespace dome::mesh
