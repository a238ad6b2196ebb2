// The voxel volume of one instant and the slabs it is cut into (seed §4.4).
//
// Frames and units: the volume is an axis-aligned box in the world frame (mm, the
// take's frame; z up in the synthetic dome). Voxel (i, j, k) has its centre at
//   origin_mm + (i + 0.5, j + 0.5, k + 0.5) * voxel_size_mm,
// i along world x, j along y, k along z. A *plane* is all voxels of one k; a *slab*
// is the planes [k0, k1). Within a slab voxels are stored plane-major, then row
// (j), then i contiguous: index = ((k - k0) * ny + j) * nx + i.
//
// Seed §4.4: "a space 6000mm x 6000mm x 6000mm ... 300x300x300 voxels ... 20mm";
// the defaults reproduce it, centred on the synthetic dome's sphere centre
// (0, 0, 250) mm so that every camera centre lies inside.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace dome::fusion {

struct VolumeGrid {
  Eigen::Vector3d origin_mm = Eigen::Vector3d(-3000.0, -3000.0, -2750.0);  // min corner, mm
  double voxel_size_mm = 20.0;  // edge of a cubic voxel, in mm
  int nx = 300;                 // voxels along world x (count)
  int ny = 300;                 // voxels along world y (count)
  int nz = 300;                 // voxels along world z = planes (count)

  // Throws core::InputError naming `where` and the field when the voxel size or a
  // count is not positive, or a value is not finite.
  void Check(const std::string& where = "volume") const;
  // Throws core::InputError naming `where` unless 0 <= k0 < k1 <= nz.
  void CheckSlab(int k0, int k1, const std::string& where = "slab") const;

  int64_t PlaneVoxels() const { return int64_t{nx} * ny; }
  Eigen::Vector3d VoxelCentreMm(double i, double j, double k) const {
    return origin_mm + Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5) * voxel_size_mm;
  }
  // A grid with the given voxel size covering the box [min_mm, max_mm].
  static VolumeGrid Covering(const Eigen::Vector3d& min_mm, const Eigen::Vector3d& max_mm,
                             double voxel_size_mm);
};

// The accumulated signed distance of the planes [k0, k1) (Curless & Levoy 1996): per
// voxel the weighted mean signed distance to the observed surfaces along each
// camera's ray, in mm (positive in front of the surface, i.e. in free space, negative
// behind it), and the sum of weights (0 = never observed; then distance is 0).
struct Slab {
  int k0 = 0;
  int k1 = 0;
  int nx = 0;
  int ny = 0;
  std::vector<float> distance_mm;
  std::vector<float> weight;

  int planes() const { return k1 - k0; }
  const float* PlaneDistance(int k) const {
    return distance_mm.data() + static_cast<int64_t>(k - k0) * nx * ny;
  }
  const float* PlaneWeight(int k) const {
    return weight.data() + static_cast<int64_t>(k - k0) * nx * ny;
  }
};

// Serialized form of a slab (a job's output, sent to the master): little-endian
//   "DOMESLAB" u32 version=3, i32 k0 k1 nx ny, then one zstd frame (content size
//   declared, with its checksum) of the voxels in order as runs: records of a u32 tag
//   whose low 31 bits are a count c >= 1 and whose top bit says which record it is:
//   set, one pair f32 distance_mm, f32 weight follows, the value of the next c voxels;
//   clear, c such pairs follow, one a voxel.
// A slab is mostly runs of one value (unobserved voxels, free space at the clamp with a
// count of views): coded as runs first, zstd has about a sixth of the bytes to compress,
// and a Robovision slab of 11 MB is encoded, and decoded, in about half the time
// version 2 took (the same compressed size).
// Version 2 was one zstd frame of f32 distance_mm[n], f32 weight[n]; version 1 had the
// floats uncompressed (8 bytes a voxel, 11.5 MB for 16 planes of 300 x 300); both are
// still read. The coding is lossless: the decoded floats are the encoded ones, bit for
// bit.
std::string EncodeSlab(const Slab& slab);
// Either version. Throws core::InputError naming `where` when the bytes are not a
// slab, are truncated or corrupt, or name more than 2^32 bytes of voxels.
Slab DecodeSlab(const std::string& bytes, const std::string& where);

}  // namespace dome::fusion
