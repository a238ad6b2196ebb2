#include "mesh/smooth.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/error.h"

namespace dome::mesh {

void SmoothOptions::Check() const {
  core::Require(iterations >= 0, "smooth_iterations",
                "must be >= 0 (0 = no smoothing), got " + std::to_string(iterations));
  core::Require(std::isfinite(lambda) && lambda > 0 && lambda <= 1, "smooth_lambda",
                "must be in (0, 1], got " + std::to_string(lambda));
  core::Require(std::isfinite(mu) && mu < -lambda && mu >= -1, "smooth_mu",
                "must be in [-1, -smooth_lambda), got " + std::to_string(mu));
}

void SmoothTaubin(const SmoothOptions& options, io::Mesh* mesh) {
  options.Check();
  if (options.iterations == 0 || mesh->faces.empty()) return;
  const size_t n = mesh->vertices.size();
  // Edge neighbours per vertex (CSR), each edge once per endpoint.
  std::vector<std::pair<int32_t, int32_t>> edges;
  edges.reserve(mesh->faces.size() * 3);
  for (const Eigen::Vector3i& f : mesh->faces) {
    for (int k = 0; k < 3; ++k) {
      const int a = f[k], b = f[(k + 1) % 3];
      DOME_CHECK(a >= 0 && size_t(a) < n && b >= 0 && size_t(b) < n,
                 "face indices are valid vertices");
      if (a != b) edges.emplace_back(std::min(a, b), std::max(a, b));
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  std::vector<size_t> start(n + 1, 0);
  for (const auto& [a, b] : edges) {
    ++start[size_t(a) + 1];
    ++start[size_t(b) + 1];
  }
  for (size_t v = 0; v < n; ++v) start[v + 1] += start[v];
  std::vector<int32_t> nbr(start[n]);
  std::vector<size_t> fill(start.begin(), start.end() - 1);
  for (const auto& [a, b] : edges) {
    nbr[fill[size_t(a)]++] = b;
    nbr[fill[size_t(b)]++] = a;
  }

  // Double precision: positions in mm far from the origin keep their sub-micron steps.
  std::vector<Eigen::Vector3d> p(n), next(n);
  for (size_t v = 0; v < n; ++v) p[v] = mesh->vertices[v].cast<double>();
  auto step = [&](double factor) {
    for (size_t v = 0; v < n; ++v) {
      const size_t b = start[v], e = start[v + 1];
      if (b == e) {
        next[v] = p[v];
        continue;
      }
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (size_t k = b; k < e; ++k) mean += p[size_t(nbr[k])];
      next[v] = p[v] + factor * (mean / double(e - b) - p[v]);
    }
    p.swap(next);
  };
  for (int i = 0; i < options.iterations; ++i) {
    step(options.lambda);
    step(options.mu);
  }
  for (size_t v = 0; v < n; ++v) mesh->vertices[v] = p[v].cast<float>();
}

}  // namespace dome::mesh
