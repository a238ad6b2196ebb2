#include "mesh/decimate.h"

#include <meshoptimizer.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/timer.h"

namespace dome::mesh {
namespace {

// For every input vertex kept in `kept_indices`, the position minimizing the
// area-weighted squared distances to the planes of the input faces of its cluster
// (input vertices assigned to the nearest kept vertex in edge hops, ties to the first
// reached); directions the planes leave undetermined (singular values below 1e-3 of
// the largest) keep the current position. Open-border vertices and vertices of
// clusters without faces stay. Returns positions for all input vertices.
std::vector<Eigen::Vector3f> RelocatedPositions(const io::Mesh& mesh,
                                                const std::vector<unsigned int>& kept_indices) {
  const size_t nv = mesh.vertices.size();
  std::vector<Eigen::Vector3f> pos = mesh.vertices;
  // Vertex adjacency (CSR) and border vertices (an edge used by one face).
  std::vector<std::pair<int, int>> edges;
  edges.reserve(mesh.faces.size() * 3);
  for (const auto& f : mesh.faces) {
    for (int m = 0; m < 3; ++m) edges.emplace_back(f[m], f[(m + 1) % 3]);
  }
  std::vector<int> start(nv + 1, 0), adj(edges.size() * 2);
  for (const auto& e : edges) {
    ++start[e.first + 1];
    ++start[e.second + 1];
  }
  for (size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (const auto& e : edges) {
    adj[fill[e.first]++] = e.second;
    adj[fill[e.second]++] = e.first;
  }
  std::vector<uint8_t> border(nv, 0);
  for (size_t v = 0; v < nv; ++v) {
    // An edge (v, w) is a border edge when it appears once in either direction.
    std::vector<int> nb(adj.begin() + start[v], adj.begin() + start[v + 1]);
    std::sort(nb.begin(), nb.end());
    for (size_t a = 0; a < nb.size();) {
      size_t b = a;
      while (b < nb.size() && nb[b] == nb[a]) ++b;
      if (b - a == 1) border[v] = 1;
      a = b;
    }
  }
  // Multi-source breadth-first search from the kept vertices.
  std::vector<int> owner(nv, -1), queue;
  queue.reserve(nv);
  for (unsigned int v : kept_indices) {
    if (owner[v] < 0) {
      owner[v] = int(v);
      queue.push_back(int(v));
    }
  }
  for (size_t q = 0; q < queue.size(); ++q) {
    const int v = queue[q];
    for (int a = start[v]; a < start[v + 1]; ++a) {
      if (owner[adj[a]] < 0) {
        owner[adj[a]] = owner[v];
        queue.push_back(adj[a]);
      }
    }
  }
  // Quadrics sum area * n n^T and area * n (n . p) per kept vertex, in coordinates
  // relative to the kept vertex (well conditioned far from the origin).
  std::vector<Eigen::Matrix3d> a_sum(nv);
  std::vector<Eigen::Vector3d> b_sum(nv);
  std::vector<uint8_t> has(nv, 0);
  for (const auto& f : mesh.faces) {
    const Eigen::Vector3d p0 = mesh.vertices[f[0]].cast<double>();
    const Eigen::Vector3d cr =
        (mesh.vertices[f[1]].cast<double>() - p0).cross(mesh.vertices[f[2]].cast<double>() - p0);
    const double twice_area = cr.norm();
    if (!(twice_area > 0)) continue;
    const Eigen::Vector3d n = cr / twice_area;
    int done[3] = {-1, -1, -1};
    for (int m = 0; m < 3; ++m) {
      const int o = owner[f[m]];
      if (o < 0 || o == done[0] || o == done[1]) continue;
      done[m] = o;
      if (!has[o]) {
        a_sum[o].setZero();
        b_sum[o].setZero();
        has[o] = 1;
      }
      const double d = n.dot(p0 - mesh.vertices[o].cast<double>());
      a_sum[o] += 0.5 * twice_area * n * n.transpose();
      b_sum[o] += 0.5 * twice_area * d * n;
    }
  }
  for (unsigned int v : kept_indices) {
    if (!has[v] || border[v]) continue;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(a_sum[v]);
    const Eigen::Vector3d lambda = eig.eigenvalues();
    const double top = lambda.maxCoeff();
    if (!(top > 0)) continue;
    Eigen::Vector3d x = Eigen::Vector3d::Zero();  // offset from the current position
    for (int k = 0; k < 3; ++k) {
      if (lambda[k] > 1e-3 * top) {
        const Eigen::Vector3d e = eig.eigenvectors().col(k);
        x += e * (e.dot(b_sum[v]) / lambda[k]);
      }
    }
    pos[v] = (mesh.vertices[v].cast<double>() + x).cast<float>();
  }
  return pos;
}

}  // namespace

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
  std::vector<Eigen::Vector3f> moved;
  if (options.relocate_vertices && n_out > 0) moved = RelocatedPositions(mesh, out);
  io::Mesh result;
  std::vector<int> remap(mesh.vertices.size(), -1);
  for (size_t f = 0; f + 2 < out.size(); f += 3) {
    Eigen::Vector3i face;
    for (int m = 0; m < 3; ++m) {
      const unsigned int v = out[f + m];
      if (remap[v] < 0) {
        remap[v] = static_cast<int>(result.vertices.size());
        result.vertices.push_back(moved.empty() ? mesh.vertices[v] : moved[v]);
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
