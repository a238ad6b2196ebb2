#include "mesh/smooth.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/disjoint_sets.h"
#include "core/error.h"
#include "core/parallel_for.h"

namespace dome::mesh {
namespace {

// Edges shorter than this fraction of the mean edge length are welded after smoothing.
constexpr double kWeldFraction = 1e-3;

}  // namespace

void SmoothOptions::Check() const {
  core::Require(iterations >= 0, "smooth_iterations",
                "must be >= 0 (0 = no smoothing), got " + std::to_string(iterations));
  core::Require(std::isfinite(lambda) && lambda > 0 && lambda <= 1, "smooth_lambda",
                "must be in (0, 1], got " + std::to_string(lambda));
  core::Require(std::isfinite(mu) && mu < -lambda && mu >= -1, "smooth_mu",
                "must be in [-1, -smooth_lambda), got " + std::to_string(mu));
  core::Require(num_threads >= 0, "smooth num_threads",
                "must be >= 0 (0 = every hardware thread), got " + std::to_string(num_threads));
}

void SmoothTaubin(const SmoothOptions& options, io::Mesh* mesh) {
  options.Check();
  if (options.iterations == 0 || mesh->faces.empty()) return;
  const size_t n = mesh->vertices.size();
  const int threads = options.num_threads;
  // Edge neighbours per vertex (CSR), each in ascending order once: every face adds both
  // directions of its three edges (an edge of two faces twice), then each vertex's list
  // is sorted and its repeats dropped. Ascending order fixes each mean's sum, so the
  // result is the same bits on any number of threads.
  std::vector<uint32_t> degree(n + 1, 0);
  for (const Eigen::Vector3i& f : mesh->faces) {
    for (int k = 0; k < 3; ++k) {
      const int a = f[k], b = f[(k + 1) % 3];
      DOME_CHECK(a >= 0 && size_t(a) < n && b >= 0 && size_t(b) < n,
                 "face indices are valid vertices");
      if (a != b) {
        ++degree[size_t(a) + 1];
        ++degree[size_t(b) + 1];
      }
    }
  }
  std::vector<size_t> slot(n + 1, 0);
  for (size_t v = 0; v < n; ++v) slot[v + 1] = slot[v] + degree[v + 1];
  std::vector<int32_t> all(slot[n]);
  {
    std::vector<size_t> fill(slot.begin(), slot.end() - 1);
    for (const Eigen::Vector3i& f : mesh->faces) {
      for (int k = 0; k < 3; ++k) {
        const int a = f[k], b = f[(k + 1) % 3];
        if (a == b) continue;
        all[fill[size_t(a)]++] = b;
        all[fill[size_t(b)]++] = a;
      }
    }
  }
  std::vector<size_t> start(n + 1, 0);
  core::ParallelFor(0, int64_t(n), threads, [&](int64_t b, int64_t e) {
    for (int64_t v = b; v < e; ++v) {
      int32_t* first = all.data() + slot[size_t(v)];
      int32_t* last = all.data() + slot[size_t(v) + 1];
      std::sort(first, last);
      start[size_t(v) + 1] = size_t(std::unique(first, last) - first);
    }
  });
  for (size_t v = 0; v < n; ++v) start[v + 1] += start[v];
  std::vector<int32_t> nbr(start[n]);
  core::ParallelFor(0, int64_t(n), threads, [&](int64_t b, int64_t e) {
    for (int64_t v = b; v < e; ++v) {
      std::copy_n(all.data() + slot[size_t(v)], start[size_t(v) + 1] - start[size_t(v)],
                  nbr.data() + start[size_t(v)]);
    }
  });
  all = {};

  // Double precision: positions in mm far from the origin keep their sub-micron steps.
  std::vector<Eigen::Vector3d> p(n), next(n);
  for (size_t v = 0; v < n; ++v) p[v] = mesh->vertices[v].cast<double>();
  // Each vertex's step reads the positions before the step only: vertices split freely.
  auto step = [&](double factor) {
    core::ParallelFor(0, int64_t(n), threads, [&](int64_t vb, int64_t ve) {
      for (size_t v = size_t(vb); v < size_t(ve); ++v) {
        const size_t b = start[v], e = start[v + 1];
        if (b == e) {
          next[v] = p[v];
          continue;
        }
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        for (size_t k = b; k < e; ++k) mean += p[size_t(nbr[k])];
        next[v] = p[v] + factor * (mean / double(e - b) - p[v]);
      }
    });
    p.swap(next);
  };
  for (int i = 0; i < options.iterations; ++i) {
    step(options.lambda);
    step(options.mu);
  }
  for (size_t v = 0; v < n; ++v) mesh->vertices[v] = p[v].cast<float>();
  // Mean edge length over the faces' edges (an edge of two faces counts twice).
  double sum = 0;
  size_t count = 0;
  for (const Eigen::Vector3i& f : mesh->faces) {
    for (int k = 0; k < 3; ++k) {
      sum += (mesh->vertices[size_t(f[k])] - mesh->vertices[size_t(f[(k + 1) % 3])])
                 .cast<double>()
                 .norm();
      ++count;
    }
  }
  if (count > 0) WeldShortEdges(kWeldFraction * sum / double(count), mesh);
}

int WeldShortEdges(double min_length, io::Mesh* mesh) {
  const size_t n = mesh->vertices.size();
  // A set's root is its least vertex index: the order stays deterministic.
  core::DisjointSets sets(n);
  auto find = [&](int32_t v) { return sets.Find(v); };
  bool any = false;
  for (const Eigen::Vector3i& f : mesh->faces) {
    for (int k = 0; k < 3; ++k) {
      const int32_t a = f[k], b = f[(k + 1) % 3];
      DOME_CHECK(a >= 0 && size_t(a) < n && b >= 0 && size_t(b) < n,
                 "face indices are valid vertices");
      if (!((mesh->vertices[size_t(a)] - mesh->vertices[size_t(b)]).cast<double>().norm() <
            min_length)) {
        continue;
      }
      sets.Union(a, b);
      any = true;
    }
  }
  if (!any) return 0;
  // Faces on the roots; those left with a repeated vertex go.
  const size_t faces_before = mesh->faces.size();
  std::vector<uint8_t> used_before(n, 0), used_after(n, 0);
  size_t out = 0;
  for (const Eigen::Vector3i& f : mesh->faces) {
    Eigen::Vector3i g;
    for (int k = 0; k < 3; ++k) {
      g[k] = find(f[k]);
      used_before[size_t(g[k])] = 1;
    }
    if (g[0] == g[1] || g[1] == g[2] || g[0] == g[2]) continue;
    for (int k = 0; k < 3; ++k) used_after[size_t(g[k])] = 1;
    mesh->faces[out++] = g;
  }
  mesh->faces.resize(out);
  // Roots keep their attributes, in order, unless the welding left them without a face.
  std::vector<int32_t> index(n, -1);
  size_t kept = 0;
  for (size_t v = 0; v < n; ++v) {
    if (find(int32_t(v)) != int32_t(v) || (used_before[v] && !used_after[v])) continue;
    index[v] = int32_t(kept);
    mesh->vertices[kept] = mesh->vertices[v];
    if (mesh->HasNormals()) mesh->normals[kept] = mesh->normals[v];
    if (mesh->HasColors()) mesh->colors[kept] = mesh->colors[v];
    if (mesh->HasAlphas()) mesh->alphas[kept] = mesh->alphas[v];
    ++kept;
  }
  mesh->vertices.resize(kept);
  if (mesh->HasNormals()) mesh->normals.resize(kept);
  if (mesh->HasColors()) mesh->colors.resize(kept);
  if (mesh->HasAlphas()) mesh->alphas.resize(kept);
  for (Eigen::Vector3i& f : mesh->faces) {
    for (int k = 0; k < 3; ++k) f[k] = index[size_t(f[k])];
  }
  return int(faces_before - out);
}

}  // namespace dome::mesh
