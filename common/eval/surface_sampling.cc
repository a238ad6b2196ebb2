#include "eval/surface_sampling.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>

#include "core/parallel_for.h"

namespace dome::eval {
namespace {

constexpr int64_t kBlock = 1 << 16;  // samples per generator

uint64_t SplitMix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// Uniform in [0, 1) from the top 53 bits: identical on every standard library
// (std::uniform_real_distribution is not specified bit for bit).
double Uniform01(std::mt19937_64& gen) { return static_cast<double>(gen() >> 11) * 0x1.0p-53; }

double TriangleArea(const std::vector<Eigen::Vector3f>& v, const Eigen::Vector3i& f) {
  const Eigen::Vector3d a = v[f[0]].cast<double>();
  return 0.5 * (v[f[1]].cast<double>() - a).cross(v[f[2]].cast<double>() - a).norm();
}

}  // namespace

double SurfaceArea(const std::vector<Eigen::Vector3f>& vertices,
                   const std::vector<Eigen::Vector3i>& faces) {
  double area = 0.0;
  for (const Eigen::Vector3i& f : faces) {
    area += TriangleArea(vertices, f);
  }
  return area;
}

std::vector<Eigen::Vector3f> SampleSurfaceUniformly(const std::vector<Eigen::Vector3f>& vertices,
                                                    const std::vector<Eigen::Vector3i>& faces,
                                                    int64_t count, uint64_t seed, int num_threads) {
  std::vector<double> cumulative(faces.size());
  double total = 0.0;
  for (size_t i = 0; i < faces.size(); ++i) {
    total += TriangleArea(vertices, faces[i]);
    cumulative[i] = total;
  }
  if (count <= 0 || !(total > 0.0)) {
    return {};
  }
  // Triangle t gets the samples [end[t-1], end[t]) with end[t] = round(count * area
  // fraction up to t): counts follow the areas up to rounding, without the binomial
  // noise of drawing a triangle per sample.
  std::vector<int64_t> end(faces.size());
  for (size_t t = 0; t < faces.size(); ++t) {
    end[t] = std::llround(static_cast<double>(count) * (cumulative[t] / total));
  }
  end.back() = count;
  std::vector<Eigen::Vector3f> samples(static_cast<size_t>(count));
  const int64_t blocks = (count + kBlock - 1) / kBlock;
  core::ParallelFor(0, blocks, num_threads, [&](int64_t block_begin, int64_t block_end) {
    for (int64_t block = block_begin; block < block_end; ++block) {
      std::mt19937_64 gen(SplitMix64(seed ^ SplitMix64(static_cast<uint64_t>(block))));
      const int64_t first = block * kBlock, last = std::min(count, first + kBlock);
      // The triangle of sample `first`: the first t with end[t] > first.
      size_t t = std::upper_bound(end.begin(), end.end(), first) - end.begin();
      for (int64_t i = first; i < last; ++i) {
        while (end[t] <= i) {
          ++t;
        }
        const double r1 = std::sqrt(Uniform01(gen)), r2 = Uniform01(gen);
        const Eigen::Vector3i& face = faces[t];
        const Eigen::Vector3d p = (1.0 - r1) * vertices[face[0]].cast<double>() +
                                  r1 * (1.0 - r2) * vertices[face[1]].cast<double>() +
                                  r1 * r2 * vertices[face[2]].cast<double>();
        samples[i] = p.cast<float>();
      }
    }
  });
  return samples;
}

}  // namespace dome::eval
