#include "fusion/volume.h"

#include <cmath>
#include <cstring>

#include "core/error.h"

namespace dome::fusion {

void VolumeGrid::Check(const std::string& where) const {
  using core::Require;
  for (int a = 0; a < 3; ++a) {
    Require(std::isfinite(origin_mm[a]), where + ": origin_mm",
            "must be finite, got " + std::to_string(origin_mm[a]));
  }
  Require(std::isfinite(voxel_size_mm) && voxel_size_mm > 0.0, where + ": voxel_size_mm",
          "must be a positive number of mm, got " + std::to_string(voxel_size_mm));
  Require(nx > 0, where + ": nx", "must be a positive voxel count, got " + std::to_string(nx));
  Require(ny > 0, where + ": ny", "must be a positive voxel count, got " + std::to_string(ny));
  Require(nz > 0, where + ": nz", "must be a positive voxel count, got " + std::to_string(nz));
  Require(int64_t{nx} * ny <= (int64_t{1} << 31), where,
          "a plane of nx * ny voxels must hold at most 2^31 voxels");
}

void VolumeGrid::CheckSlab(int k0, int k1, const std::string& where) const {
  core::Require(0 <= k0 && k0 < k1 && k1 <= nz, where,
                "planes [" + std::to_string(k0) + ", " + std::to_string(k1) +
                    ") are not a non-empty range inside the volume's planes [0, " +
                    std::to_string(nz) + ")");
}

VolumeGrid VolumeGrid::Covering(const Eigen::Vector3d& min_mm, const Eigen::Vector3d& max_mm,
                                double voxel_size_mm) {
  VolumeGrid grid;
  grid.origin_mm = min_mm;
  grid.voxel_size_mm = voxel_size_mm;
  const Eigen::Vector3d extent = max_mm - min_mm;
  grid.nx = static_cast<int>(std::ceil(extent.x() / voxel_size_mm));
  grid.ny = static_cast<int>(std::ceil(extent.y() / voxel_size_mm));
  grid.nz = static_cast<int>(std::ceil(extent.z() / voxel_size_mm));
  return grid;
}

namespace {
constexpr char kSlabMagic[8] = {'D', 'O', 'M', 'E', 'S', 'L', 'A', 'B'};
template <typename T>
void Put(std::string* out, T v) {
  out->append(reinterpret_cast<const char*>(&v), sizeof(T));
}
}  // namespace

std::string EncodeSlab(const Slab& slab) {
  std::string out(kSlabMagic, 8);
  Put<uint32_t>(&out, 1);
  Put<int32_t>(&out, slab.k0);
  Put<int32_t>(&out, slab.k1);
  Put<int32_t>(&out, slab.nx);
  Put<int32_t>(&out, slab.ny);
  out.append(reinterpret_cast<const char*>(slab.distance_mm.data()),
             slab.distance_mm.size() * sizeof(float));
  out.append(reinterpret_cast<const char*>(slab.weight.data()), slab.weight.size() * sizeof(float));
  return out;
}

Slab DecodeSlab(const std::string& bytes, const std::string& where) {
  constexpr size_t kHeader = 8 + 4 + 16;
  core::Require(bytes.size() >= kHeader && std::memcmp(bytes.data(), kSlabMagic, 8) == 0, where,
                "not a dome slab (expected the 'DOMESLAB' header)");
  uint32_t version;
  int32_t h[4];
  std::memcpy(&version, bytes.data() + 8, 4);
  std::memcpy(h, bytes.data() + 12, 16);
  core::Require(
      version == 1, where,
      "slab format version " + std::to_string(version) + " is not the supported version 1");
  Slab slab;
  slab.k0 = h[0];
  slab.k1 = h[1];
  slab.nx = h[2];
  slab.ny = h[3];
  core::Require(slab.k1 > slab.k0 && slab.nx > 0 && slab.ny > 0, where,
                "slab header has an empty plane range or size");
  const size_t n = size_t(slab.k1 - slab.k0) * size_t(slab.nx) * size_t(slab.ny);
  core::Require(bytes.size() == kHeader + 2 * n * sizeof(float), where,
                "slab of " + std::to_string(n) + " voxels must be " +
                    std::to_string(kHeader + 2 * n * sizeof(float)) + " bytes, got " +
                    std::to_string(bytes.size()));
  slab.distance_mm.resize(n);
  slab.weight.resize(n);
  std::memcpy(slab.distance_mm.data(), bytes.data() + kHeader, n * sizeof(float));
  std::memcpy(slab.weight.data(), bytes.data() + kHeader + n * sizeof(float), n * sizeof(float));
  return slab;
}

}  // namespace dome::fusion
