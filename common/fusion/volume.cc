#include "fusion/volume.h"

#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <mutex>
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
// zstd's fastest level: after the runs are coded (below) what is left is the voxels
// near the surfaces, which compress little at any level.
constexpr int kSlabZstdLevel = 1;
// The version EncodeSlab writes (volume.h).
constexpr uint32_t kSlabVersion = 3;
// A run record's tag: the top bit, the count below it.
constexpr uint32_t kRunBit = 0x80000000u, kMaxCount = 0x7fffffffu;
// Identical voxels shorter than this stay in a literal record: a run record costs a tag
// and a pair, and breaking a literal record costs another tag.
constexpr size_t kMinRun = 3;

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
// kPooledEncoders kept), each about 1.5 slabs of memory (the runs' worst case) and
// zstd's bound of what they held.
constexpr size_t kPooledEncoders = 4;
struct SlabEncoder {
  std::vector<char> raw, compressed;  // the runs (version 3's records), zstd's frame
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

namespace {

// A voxel's distance and weight bits as one word (the weight's in the high half).
inline uint64_t PairBits(const float* d, const float* w, size_t i) {
  uint32_t a, b;
  std::memcpy(&a, d + i, 4);
  std::memcpy(&b, w + i, 4);
  return uint64_t(a) | uint64_t(b) << 32;
}

// Version 3's records of the n voxels of d and w, into the start of *out (grown to hold
// the most they can take); returns their bytes.
size_t CodeRuns(const float* d, const float* w, size_t n, std::vector<char>* out) {
  // At most a tag and a pair a voxel (a literal record of one voxel each time). The
  // buffer only grows: a slab's voxels are megabytes, and shrinking it after each slab
  // had the next one zero-fill its regrown part.
  if (out->size() < n * 12 + 8) out->resize(n * 12 + 8);
  char* at = out->data();
  const auto put_tag = [&](uint32_t tag) {
    std::memcpy(at, &tag, 4);
    at += 4;
  };
  const auto put_pair = [&](size_t i) {
    std::memcpy(at, d + i, 4);
    std::memcpy(at + 4, w + i, 4);
    at += 8;
  };
  const auto put_literals = [&](size_t from, size_t to) {
    while (from < to) {
      const size_t c = std::min<size_t>(to - from, kMaxCount);
      put_tag(uint32_t(c));
      for (size_t i = from; i < from + c; ++i) put_pair(i);
      from += c;
    }
  };
  size_t literal = 0, i = 0;
  while (i < n) {
    const uint64_t value = PairBits(d, w, i);
    size_t j = i + 1;
    while (j < n && PairBits(d, w, j) == value) ++j;
    if (j - i >= kMinRun) {
      put_literals(literal, i);
      for (size_t from = i; from < j;) {
        const size_t c = std::min<size_t>(j - from, kMaxCount);
        put_tag(kRunBit | uint32_t(c));
        put_pair(i);
        from += c;
      }
      literal = j;
    }
    i = j;
  }
  put_literals(literal, n);
  return size_t(at - out->data());
}

// The content of the zstd frame `payload`, whose declared size the caller has checked;
// throws core::InputError naming `where` when it does not decompress to that size.
std::string Decompress(const char* payload, size_t payload_size, uint64_t declared,
                       const std::string& where) {
  std::string out(size_t(declared), '\0');
  const size_t got = ZSTD_decompress(out.data(), out.size(), payload, payload_size);
  core::Require(!ZSTD_isError(got) && got == out.size(), where,
                "compressed payload of " + std::to_string(payload_size) +
                    " bytes does not decompress: " +
                    (ZSTD_isError(got) ? std::string(ZSTD_getErrorName(got))
                                       : std::to_string(got) + " bytes out"));
  return out;
}

// The n voxels that version 3's records `runs` code, into d and w; false when the
// records are malformed (a count of 0, past the slab's end, short of it, or cut short).
bool DecodeRuns(const char* runs, size_t size, size_t n, float* d, float* w) {
  size_t pos = 0, at = 0;
  while (at < size) {
    if (size - at < 4) return false;
    uint32_t tag;
    std::memcpy(&tag, runs + at, 4);
    at += 4;
    const size_t c = tag & kMaxCount;
    if (c == 0 || c > n - pos) return false;
    if (tag & kRunBit) {
      if (size - at < 8) return false;
      float dv, wv;
      std::memcpy(&dv, runs + at, 4);
      std::memcpy(&wv, runs + at + 4, 4);
      at += 8;
      std::fill(d + pos, d + pos + c, dv);
      std::fill(w + pos, w + pos + c, wv);
    } else {
      if ((size - at) / 8 < c) return false;
      for (size_t k = 0; k < c; ++k, at += 8) {
        std::memcpy(d + pos + k, runs + at, 4);
        std::memcpy(w + pos + k, runs + at + 4, 4);
      }
    }
    pos += c;
  }
  return pos == n;
}

}  // namespace

std::string EncodeSlab(const Slab& slab) {
  const size_t n = slab.distance_mm.size();
  DOME_CHECK(slab.weight.size() == n, "a slab has as many weights as distances");
  std::unique_ptr<SlabEncoder> lent = Encoders().Take();
  SlabEncoder& e = *lent;
  const size_t runs = CodeRuns(slab.distance_mm.data(), slab.weight.data(), n, &e.raw);
  if (e.compressed.size() < ZSTD_compressBound(runs)) e.compressed.resize(ZSTD_compressBound(runs));
  // With the frame's checksum, so that a corrupt slab fails to decode. The context's
  // parameters are set anew for each slab: the same bytes as a fresh context gives.
  ZSTD_CCtx_reset(e.cctx, ZSTD_reset_session_and_parameters);
  ZSTD_CCtx_setParameter(e.cctx, ZSTD_c_compressionLevel, kSlabZstdLevel);
  ZSTD_CCtx_setParameter(e.cctx, ZSTD_c_checksumFlag, 1);
  const size_t size =
      ZSTD_compress2(e.cctx, e.compressed.data(), e.compressed.size(), e.raw.data(), runs);
  DOME_CHECK(!ZSTD_isError(size), "zstd compresses into a buffer of its own bound");
  std::string out(kSlabMagic, 8);
  out.reserve(kSlabHeader + size);
  Put<uint32_t>(&out, kSlabVersion);
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
      version >= 1 && version <= 3, where,
      "slab format version " + std::to_string(version) + " is not a supported version (1, 2, 3)");
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
  if (version == 3) {
    // The records of n voxels take at most 12 bytes a voxel (CodeRuns).
    const unsigned long long declared = ZSTD_getFrameContentSize(payload, payload_size);
    core::Require(declared != ZSTD_CONTENTSIZE_UNKNOWN && declared != ZSTD_CONTENTSIZE_ERROR &&
                      declared <= 12 * n + 8,
                  where,
                  "compressed payload of " + std::to_string(payload_size) +
                      " bytes does not declare the runs of a slab of " + std::to_string(n) +
                      " voxels");
    const std::string runs = Decompress(payload, payload_size, declared, where);
    slab.distance_mm.resize(n);
    slab.weight.resize(n);
    core::Require(
        DecodeRuns(runs.data(), runs.size(), n, slab.distance_mm.data(), slab.weight.data()), where,
        "the runs of the payload do not code the slab's " + std::to_string(n) + " voxels");
    return slab;
  }
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
    decompressed = Decompress(payload, payload_size, raw_size, where);
    payload = decompressed.data();
  }
  slab.distance_mm.resize(n);
  slab.weight.resize(n);
  std::memcpy(slab.distance_mm.data(), payload, n * sizeof(float));
  std::memcpy(slab.weight.data(), payload + n * sizeof(float), n * sizeof(float));
  return slab;
}

}  // namespace dome::fusion
