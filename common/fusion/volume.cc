#include "fusion/volume.h"

#include <zstd.h>

#include <cmath>
#include <cstring>
#include <mutex>
#include <memory>
#include <vector>

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
constexpr size_t kSlabHeader = 8 + 4 + 16;
// The largest slab a decoder allocates (distances and weights), bytes: a whole
// 300^3 volume is 216 MB; this stops a corrupt header from asking for more.
constexpr uint64_t kMaxSlabBytes = uint64_t{1} << 32;
// zstd's fastest level: slabs are mostly runs of unobserved or free-space voxels,
// which compress well at any level; the time goes to the workers' fusion.
constexpr int kSlabZstdLevel = 1;

template <typename T>
void Put(std::string* out, T v) {
  out->append(reinterpret_cast<const char*>(&v), sizeof(T));
}
}  // namespace

namespace {

// What encoding a slab needs besides its result, kept for the process: a slab is
// megabytes (a paper slab 11.5 MB, twice that for the compressor's bound), and the
// buffers and the compressor's workspace made fresh for every slab were mostly page
// faults; how many depended on the allocator's state, so the same slab took from 1x to
// 3.5x the time to encode. A worker runs each job on a thread of its own, so they are
// lent from a pool rather than kept per thread: one per slab encoded at once (at most
// kPooledEncoders kept), each about 2.2 slabs of memory.
constexpr size_t kPooledEncoders = 4;
struct SlabEncoder {
  std::vector<char> raw, compressed;
  ZSTD_CCtx* cctx = nullptr;
  SlabEncoder() {
    cctx = ZSTD_createCCtx();
    DOME_CHECK(cctx != nullptr, "zstd allocates a compression context");
  }
  ~SlabEncoder() { ZSTD_freeCCtx(cctx); }
  SlabEncoder(const SlabEncoder&) = delete;
  SlabEncoder& operator=(const SlabEncoder&) = delete;
};

class EncoderPool {
 public:
  std::unique_ptr<SlabEncoder> Take() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!free_.empty()) {
        std::unique_ptr<SlabEncoder> e = std::move(free_.back());
        free_.pop_back();
        return e;
      }
    }
    return std::make_unique<SlabEncoder>();
  }
  void Give(std::unique_ptr<SlabEncoder> e) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (free_.size() < kPooledEncoders) free_.push_back(std::move(e));
  }

 private:
  std::mutex mutex_;
  std::vector<std::unique_ptr<SlabEncoder>> free_;
};

EncoderPool& Encoders() {
  static auto* pool = new EncoderPool();  // never destroyed: workers may outlive statics
  return *pool;
}

}  // namespace

std::string EncodeSlab(const Slab& slab) {
  const size_t n = slab.distance_mm.size();
  DOME_CHECK(slab.weight.size() == n, "a slab has as many weights as distances");
  std::unique_ptr<SlabEncoder> lent = Encoders().Take();
  SlabEncoder& e = *lent;
  // Distances then weights, as one buffer for the compressor.
  e.raw.resize(2 * n * sizeof(float));
  std::memcpy(e.raw.data(), slab.distance_mm.data(), n * sizeof(float));
  std::memcpy(e.raw.data() + n * sizeof(float), slab.weight.data(), n * sizeof(float));
  e.compressed.resize(ZSTD_compressBound(e.raw.size()));
  // With the frame's checksum, so that a corrupt slab fails to decode. The context's
  // parameters are set anew for each slab: the same bytes as a fresh context gives.
  ZSTD_CCtx_reset(e.cctx, ZSTD_reset_session_and_parameters);
  ZSTD_CCtx_setParameter(e.cctx, ZSTD_c_compressionLevel, kSlabZstdLevel);
  ZSTD_CCtx_setParameter(e.cctx, ZSTD_c_checksumFlag, 1);
  const size_t size = ZSTD_compress2(e.cctx, e.compressed.data(), e.compressed.size(),
                                     e.raw.data(), e.raw.size());
  DOME_CHECK(!ZSTD_isError(size), "zstd compresses into a buffer of its own bound");
  std::string out(kSlabMagic, 8);
  out.reserve(kSlabHeader + size);
  Put<uint32_t>(&out, 2);
  Put<int32_t>(&out, slab.k0);
  Put<int32_t>(&out, slab.k1);
  Put<int32_t>(&out, slab.nx);
  Put<int32_t>(&out, slab.ny);
  out.append(e.compressed.data(), size);
  Encoders().Give(std::move(lent));
  return out;
}

Slab DecodeSlab(const std::string& bytes, const std::string& where) {
  core::Require(bytes.size() >= kSlabHeader && std::memcmp(bytes.data(), kSlabMagic, 8) == 0, where,
                "not a dome slab (expected the 'DOMESLAB' header)");
  uint32_t version;
  int32_t h[4];
  std::memcpy(&version, bytes.data() + 8, 4);
  std::memcpy(h, bytes.data() + 12, 16);
  core::Require(
      version == 1 || version == 2, where,
      "slab format version " + std::to_string(version) + " is not a supported version (1, 2)");
  Slab slab;
  slab.k0 = h[0];
  slab.k1 = h[1];
  slab.nx = h[2];
  slab.ny = h[3];
  core::Require(slab.k1 > slab.k0 && slab.nx > 0 && slab.ny > 0, where,
                "slab header has an empty plane range or size");
  const uint64_t n = uint64_t(int64_t{slab.k1} - slab.k0) * uint64_t(slab.nx) * uint64_t(slab.ny);
  core::Require(n <= kMaxSlabBytes / (2 * sizeof(float)), where,
                "slab header names " + std::to_string(n) + " voxels, more than a slab may hold");
  const uint64_t raw_size = 2 * n * sizeof(float);
  const char* payload = bytes.data() + kSlabHeader;
  const size_t payload_size = bytes.size() - kSlabHeader;
  std::string decompressed;
  if (version == 1) {
    core::Require(payload_size == raw_size, where,
                  "slab of " + std::to_string(n) + " voxels must be " +
                      std::to_string(kSlabHeader + raw_size) + " bytes, got " +
                      std::to_string(bytes.size()));
  } else {
    const unsigned long long declared = ZSTD_getFrameContentSize(payload, payload_size);
    core::Require(declared == raw_size, where,
                  "compressed payload of " + std::to_string(payload_size) +
                      " bytes does not declare the " + std::to_string(raw_size) +
                      " bytes of a slab of " + std::to_string(n) + " voxels");
    decompressed.resize(raw_size);
    const size_t got = ZSTD_decompress(decompressed.data(), raw_size, payload, payload_size);
    core::Require(!ZSTD_isError(got) && got == raw_size, where,
                  "compressed payload of " + std::to_string(payload_size) +
                      " bytes does not decompress: " +
                      (ZSTD_isError(got) ? std::string(ZSTD_getErrorName(got))
                                         : std::to_string(got) + " bytes out"));
    payload = decompressed.data();
  }
  slab.distance_mm.resize(n);
  slab.weight.resize(n);
  std::memcpy(slab.distance_mm.data(), payload, n * sizeof(float));
  std::memcpy(slab.weight.data(), payload + n * sizeof(float), n * sizeof(float));
  return slab;
}

}  // namespace dome::fusion
