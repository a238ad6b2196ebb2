// Uniform random points on a triangle mesh surface.
//
// Each triangle gets a number of samples proportional to its area (stratified: the
// k-th triangle receives round(N * area fraction of triangles 0..k) minus what the
// ones before it received), and each sample is placed with the square-root
// barycentric map of Osada et al., "Shape distributions" (2002):
// p = (1 - sqrt(r1)) a + sqrt(r1)(1 - r2) b + sqrt(r1) r2 c, uniform over the
// triangle. This is the scheme of Open3D's sample_points_uniformly, which
// eval_cloud.py uses; the stratification removes the binomial noise of drawing a
// triangle per sample (counts of samples inside a region vary far less). The draws
// come from per-block generators seeded from `seed` and the block number, so the
// sample is identical for any thread count.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace dome::eval {

// Total area of the triangles, in squared input units.
double SurfaceArea(const std::vector<Eigen::Vector3f>& vertices,
                   const std::vector<Eigen::Vector3i>& faces);

// `count` points uniformly distributed over the surface (input units). A mesh with
// no area gives an empty result.
std::vector<Eigen::Vector3f> SampleSurfaceUniformly(const std::vector<Eigen::Vector3f>& vertices,
                                                    const std::vector<Eigen::Vector3i>& faces,
                                                    int64_t count, uint64_t seed,
                                                    int num_threads = 0);

}  // namespace dome::eval
