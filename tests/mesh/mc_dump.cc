// Writes analytic signed-distance volumes and dome's marching-cubes mesh of each, for
// the scikit-image comparison (skimage_compare.py):
//   OUT/<name>.raw   float32 little-endian, nz x ny x nx (i fastest)
//   OUT/<name>.json  {"nx":..,"ny":..,"nz":..,"voxel_size_mm":..,"origin_mm":[..]}
//   OUT/<name>.ply   dome's mesh (binary PLY, world mm)
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "core/json.h"
#include "io/file_util.h"
#include "io/ply.h"
#include "mesh/marching_cubes.h"

namespace {

using dome::fusion::VolumeGrid;

template <typename F>
void Dump(const std::filesystem::path& out, const std::string& name, const VolumeGrid& g, F f) {
  std::vector<float> d, w;
  for (int k = 0; k < g.nz; ++k)
    for (int j = 0; j < g.ny; ++j)
      for (int i = 0; i < g.nx; ++i) {
        d.push_back(float(f(g.VoxelCentreMm(i, j, k))));
        w.push_back(1.0f);
      }
  dome::io::WriteFileAtomically(out / (name + ".raw"),
                                std::string(reinterpret_cast<const char*>(d.data()), d.size() * 4));
  const dome::core::Json json = {
      {"nx", g.nx},
      {"ny", g.ny},
      {"nz", g.nz},
      {"voxel_size_mm", g.voxel_size_mm},
      {"origin_mm", {g.origin_mm.x(), g.origin_mm.y(), g.origin_mm.z()}}};
  dome::io::WriteFileAtomically(out / (name + ".json"), dome::core::DumpJson(json) + "\n");
  dome::io::WritePly(out / (name + ".ply"), dome::mesh::MarchingCubes(g, d, w));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: mc_dump OUT_DIR\n");
    return 2;
  }
  const std::filesystem::path out = argv[1];
  std::filesystem::create_directories(out);
  VolumeGrid g;
  g.voxel_size_mm = 2.0;
  g.nx = 64;
  g.ny = 56;
  g.nz = 48;
  g.origin_mm = Eigen::Vector3d(-64, -56, -48);
  Dump(out, "sphere", g, [](const Eigen::Vector3d& p) {
    return (p - Eigen::Vector3d(0.31, -0.17, 0.23)).norm() - 37.0;
  });
  Dump(out, "torus", g, [](const Eigen::Vector3d& p) {
    const double q = std::hypot(p.x() - 0.2, p.y() + 0.1) - 36.0;
    return std::hypot(q, p.z() - 0.3) - 11.0;
  });
  // A blobby field: three overlapping spheres (smooth min) -- saddles, necks.
  Dump(out, "blobs", g, [](const Eigen::Vector3d& p) {
    const double a = (p - Eigen::Vector3d(-20, 0, 0)).norm() - 22;
    const double b = (p - Eigen::Vector3d(22, 5, 3)).norm() - 18;
    const double c = (p - Eigen::Vector3d(0, -25, -10)).norm() - 12;
    const double k = 8.0;
    auto smin = [k](double x, double y) {
      const double h = std::max(k - std::abs(x - y), 0.0) / k;
      return std::min(x, y) - h * h * k * 0.25;
    };
    return smin(smin(a, b), c);
  });
  return 0;
}
