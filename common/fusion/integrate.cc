#include "fusion/integrate.h"

#include <sys/mman.h>

#include <Eigen/LU>
#include <Eigen/QR>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <new>
#include <vector>

#if defined(__AVX2__) || defined(__F16C__)
#include <immintrin.h>
#endif
// The 16-lane paths (ExactRowPair, the per-voxel result) need these AVX-512 subsets.
#if defined(__AVX512F__) && defined(__AVX512DQ__) && defined(__AVX512BW__) && \
    defined(__AVX512VL__) && defined(__FMA__)
#define DOME_FUSION_AVX512 1
#else
#define DOME_FUSION_AVX512 0
#endif

#include "core/error.h"
#include "core/memory.h"
#include "core/parallel_for.h"
#include "fusion/consistency.h"
#include "io/depth_tiff.h"

namespace dome::fusion {
namespace {

constexpr int kLutSize = 1024;  // entries of the distortion table lambda(rn^2)
constexpr int kTileShift = 2;   // tiles of 2^kTileShift quads a side (CameraTables::tile)

}  // namespace

void FusionOptions::Check() const {
  using core::Require;
  Require(std::isfinite(truncation_mm) && truncation_mm > 0.0, "fusion: truncation_mm",
          "must be a positive number of mm, got " + std::to_string(truncation_mm));
  Require(std::isfinite(front_clamp_mm) && front_clamp_mm > 0.0, "fusion: front_clamp_mm",
          "must be a positive number of mm, got " + std::to_string(front_clamp_mm));
  Require(std::isfinite(max_depth_jump_ratio) && max_depth_jump_ratio >= 0.0,
          "fusion: max_depth_jump_ratio",
          "must be a fraction >= 0, got " + std::to_string(max_depth_jump_ratio));
  Require(std::isfinite(min_depth_mm) && min_depth_mm > 0.0, "fusion: min_depth_mm",
          "must be a positive number of mm, got " + std::to_string(min_depth_mm));
  Require(min_consistent_views >= 0, "fusion: min_consistent_views",
          "must be >= 0 (0 = off), got " + std::to_string(min_consistent_views));
  Require(std::isfinite(consistency_tolerance_mm) && consistency_tolerance_mm > 0.0,
          "fusion: consistency_tolerance_mm",
          "must be a positive number of mm, got " + std::to_string(consistency_tolerance_mm));
  Require(std::isfinite(min_weight) && min_weight >= 0.0, "fusion: min_weight",
          "must be >= 0, got " + std::to_string(min_weight));
}

void CheckRangeImage(const RangeImage& image) {
  const std::string where =
      image.where.empty() ? "range image of camera " + image.camera.id : image.where;
  image.camera.Check(where + ": camera");
  core::Require(!(image.distorted_pixels && image.camera.lens.Any()), where,
                "a depth map on the distorted pixels of a camera with an OpenCV lens is not "
                "supported (fusion projects through Tsai's kappa1 only): give it on the ideal "
                "camera's pixels");
  core::Require(!image.depth_mm.empty() && image.depth_mm.type() == CV_32FC1, where,
                "depth map must be a 32-bit float single-channel image");
  core::Require(
      image.depth_mm.cols == image.camera.width_px && image.depth_mm.rows == image.camera.height_px,
      where,
      "depth map is " + std::to_string(image.depth_mm.cols) + "x" +
          std::to_string(image.depth_mm.rows) + " but camera " + image.camera.id + " is " +
          std::to_string(image.camera.width_px) + "x" + std::to_string(image.camera.height_px));
  io::CheckDepthMap(image.depth_mm, where);
  if (!image.weight.empty()) {
    core::Require(image.weight.type() == CV_32FC1 && image.weight.size() == image.depth_mm.size(),
                  where + ": weight", "must be a 32-bit float map of the depth map's size");
    for (int y = 0; y < image.weight.rows; ++y) {
      const float* row = image.weight.ptr<float>(y);
      for (int x = 0; x < image.weight.cols; ++x) {
        core::Require(std::isfinite(row[x]) && row[x] >= 0.0f, where + ": weight",
                      "must be finite and >= 0; pixel (" + std::to_string(x) + ", " +
                          std::to_string(y) + ") is " + std::to_string(row[x]));
      }
    }
  }
}

namespace {
// A fixed-size array in the integrator's table arena (below).
template <typename T>
struct Table {
  T* ptr = nullptr;
  size_t n = 0;
  T* data() const { return ptr; }
  T& operator[](size_t i) const { return ptr[i]; }
  size_t size() const { return n; }
  bool empty() const { return n == 0; }
  T* begin() const { return ptr; }
  T* end() const { return ptr + n; }
};
constexpr size_t kTableAlign = 64;  // bytes; every table starts on a cache line
constexpr size_t kArenaStep = size_t(2) << 20;  // bytes; arena sizes are multiples
}  // namespace

// One mapping holds every camera's tables (tens to hundreds of MB), in the pages the
// process chose (core::ChoosePageSize: 2 MB pages where they fault in faster, else 4 KB).
// The hot loop's lookups across every camera's tables ran no faster in 2 MB pages
// (fusion_bench on the paper instant, the mapping reused: 0.37 s either way), but a
// fresh page's first touch costs very differently from one machine to another: with the
// tables of a Robovision instant (12 cameras of 1.3 MP) its fusion stage took 0.66-0.76
// s of wall in 2 MB pages against 0.47-0.50 s in 4 KB pages on a virtual machine where
// huge pages fault in slowly (and the other way round where small ones do).
// A process keeps the largest mapping it has freed and hands it to the next integrator
// that fits: a worker fuses instant after instant of the same size, and faulting in
// (and zeroing) the tables per instant was a visible part of building them. Sizes are
// rounded up to 2 MB so that instants of nearly the same size reuse one mapping.
// Every table byte is written before it is read, so a reused mapping needs no clearing.
struct Integrator::Arena {
  explicit Arena(size_t bytes) {
    // At least one step: an instant with no depth in any camera has no tables, and a
    // mapping of 0 bytes is refused.
    const size_t need = std::max(kArenaStep, (bytes + kArenaStep - 1) & ~(kArenaStep - 1));
    {
      std::lock_guard<std::mutex> lock(CacheMutex());
      Mapping& cached = Cached();
      if (cached.base != nullptr && cached.size >= need) {
        map = cached;
        cached = Mapping();
        return;
      }
    }
    map.size = need;
    map.base = mmap(nullptr, map.size, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (map.base == MAP_FAILED) throw std::bad_alloc();
    core::AdviseHugePages(map.base, map.size);
  }
  ~Arena() {
    Mapping drop = map;
    {
      std::lock_guard<std::mutex> lock(CacheMutex());
      Mapping& cached = Cached();
      if (cached.size < map.size) std::swap(cached, drop);
    }
    if (drop.base != nullptr) munmap(drop.base, drop.size);
  }
  Arena(const Arena&) = delete;
  Arena& operator=(const Arena&) = delete;
  char* start() const { return static_cast<char*>(map.base); }

 private:
  struct Mapping {
    void* base = nullptr;
    size_t size = 0;  // bytes mapped at base
  };
  static std::mutex& CacheMutex() {
    static std::mutex m;
    return m;
  }
  static Mapping& Cached() {  // the idle mapping kept for the next integrator
    static Mapping m;
    return m;
  }
  Mapping map;
};

namespace {
// Hands out the tables of one camera from its region of the arena.
class TableRegion {
 public:
  TableRegion(char* begin, size_t bytes) : next_(begin), end_(begin + bytes) {}
  template <typename T>
  Table<T> Take(size_t n) {
    Table<T> t;
    t.ptr = reinterpret_cast<T*>(next_);
    t.n = n;
    next_ += (n * sizeof(T) + kTableAlign - 1) / kTableAlign * kTableAlign;
    DOME_CHECK(next_ <= end_, "a camera's tables fit the region sized for them");
    return t;
  }

 private:
  char* next_;
  char* end_;
};

size_t TableBytes(size_t n, size_t element) {
  return (n * element + kTableAlign - 1) / kTableAlign * kTableAlign;
}
}  // namespace

// Everything the hot loop needs about one camera, in float, contiguous.
struct Integrator::CameraTables {
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation_mm;
  // Camera-frame centre of voxel (i, j, k) = q000 + i ex + j ey + k ez, mm.
  Eigen::Vector3d q000, ex, ey, ez;
  bool lambda_monotonic = true;  // lambda non-decreasing or non-increasing over rn^2
  float fx_px = 0, fy_px = 0, cx_px = 0, cy_px = 0;  // normalized -> pixel (times lambda)
  float rn2_max = 0;                                 // largest tabulated (x/z)^2 + (y/z)^2
  float lut_scale = 0;                               // (kLutSize - 1) / rn2_max
  Table<float> lambda;  // distortion factor over rn^2, kLutSize entries
  // lambda[e], lambda[e + 1] side by side (the last entry repeated): the hot loop
  // fetches both ends of its interval with one 8-byte load.
  Table<float> lambda_pair;
  // With lambda_poly the kernel evaluates lambda as the polynomial lambda_c in
  // x = rn^2 * poly_scale (FitDistortionPolynomial) instead of reading the table: no
  // lookups in the hottest path. ClassifyBlock bounds lambda by the polynomial at a
  // block's ends, widened by lambda_slack.
  bool lambda_poly = false;
  float lambda_c[5] = {1, 0, 0, 0, 0};
  float poly_scale = 0;
  double lambda_slack = 0;
  double xn_min = 0, xn_max = 0, yn_min = 0, yn_max = 0;  // frustum, normalized coords
  int width = 0, height = 0;
  Table<float> inv_depth;  // 1 / depth, 0 where invalid; width x height
  Table<float> weight;     // empty = uniform
  // (width-1) x (height-1): bit 0 upper, bit 1 lower triangle (plus 3 unused entries
  // at the end, the same count as quad_range's pairs).
  Table<uint8_t> quad;
  // Per quad, side by side (2 floats, one 8-byte load): least and largest of its valid
  // depths (+inf / -inf if none), mm; any depth interpolated in a triangle of the quad
  // lies between them. The least carries the quad's two triangle bits in the two low
  // bits of its pattern, lowered first so that the value stays below the true least
  // depth (one load gives both). QuadMin / QuadMax below read them.
  Table<float> quad_range;
  float QuadMin(size_t q) const { return quad_range[2 * q]; }
  float QuadMax(size_t q) const { return quad_range[2 * q + 1]; }
  // Per tile of 2^kTileShift x 2^kTileShift quads, two IEEE half floats, mm: low 16
  // bits the least QuadMin of the tile rounded down when every quad has both
  // triangles (-inf otherwise), high 16 bits the largest QuadMax rounded up. 20 KB per
  // camera, so that most voxels of an exact row are found to be clamped free space or
  // far behind with one small lookup instead of the per-quad tables.
  int tile_w = 0;
  Table<uint32_t> tile;
  // Min/max depth pyramid over the quads for block culling. Level 0 is the quads
  // themselves (QuadMin: just below the least depth where both triangles exist;
  // QuadMax; connected = both triangles exist); pyramid[l - 1] holds level l >= 1, each
  // cell merging 2x2 cells of level l - 1: min (meaningful only where connected), max
  // (-inf if no valid depth), connected = all connected.
  struct Level {
    int width = 0, height = 0;
    Table<float> min_depth, max_depth;
    Table<uint8_t> connected;
  };
  std::vector<Level> pyramid;
};

namespace {
// Pyramid levels 1.. over a (qw) x (qh) grid of quads: their sizes.
template <typename F>
void ForEachPyramidLevel(int qw, int qh, F&& level) {
  if (qw < 1 || qh < 1) return;
  do {
    qw = (qw + 1) / 2;
    qh = (qh + 1) / 2;
    level(qw, qh);
  } while (qw > 1 || qh > 1);
}

// Bytes of the tables of a width x height camera (see CameraTables).
size_t CameraTableBytes(int w, int h, bool weighted) {
  const size_t px = size_t(w) * h, quads = size_t(std::max(w - 1, 0)) * std::max(h - 1, 0) + 3;
  const size_t tiles = size_t(((w - 1) >> kTileShift) + 1) * (((h - 1) >> kTileShift) + 1);
  size_t bytes = TableBytes(kLutSize, 4) + TableBytes(2 * kLutSize, 4) +
                 TableBytes(px, 4) * (weighted ? 2 : 1) + TableBytes(quads, 1) +
                 TableBytes(2 * quads, 4) + TableBytes(tiles, 4);
  ForEachPyramidLevel(w - 1, h - 1, [&](int lw, int lh) {
    bytes += 2 * TableBytes(size_t(lw) * lh, 4) + TableBytes(size_t(lw) * lh, 1);
  });
  return bytes;
}

// Levels 1.. of CameraTables::pyramid from the quad tables, in the camera's region.
void BuildPyramid(Integrator::CameraTables* t, TableRegion* region) {
  using Level = Integrator::CameraTables::Level;
  const float inf = std::numeric_limits<float>::infinity();
  t->pyramid.clear();
  const int qw = t->width - 1, qh = t->height - 1;
  if (qw < 1 || qh < 1) return;
  auto merge_into = [inf, region](Level* b, int width, int height, auto&& cell) {
    b->width = (width + 1) / 2;
    b->height = (height + 1) / 2;
    const size_t cells = size_t(b->width) * b->height;
    b->min_depth = region->Take<float>(cells);
    b->max_depth = region->Take<float>(cells);
    b->connected = region->Take<uint8_t>(cells);
    std::fill(b->min_depth.begin(), b->min_depth.end(), inf);
    std::fill(b->max_depth.begin(), b->max_depth.end(), -inf);
    std::fill(b->connected.begin(), b->connected.end(), uint8_t{1});
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        float lo, hi;
        bool connected;
        cell(x, y, &lo, &hi, &connected);
        const size_t d = size_t(y / 2) * b->width + x / 2;
        b->min_depth[d] = std::min(b->min_depth[d], lo);
        b->max_depth[d] = std::max(b->max_depth[d], hi);
        b->connected[d] = b->connected[d] && connected;
      }
    }
  };
  Level l1;
  merge_into(&l1, qw, qh, [&](int x, int y, float* lo, float* hi, bool* connected) {
    const size_t q = size_t(y) * qw + x;
    *lo = t->QuadMin(q);
    *hi = t->QuadMax(q);
    *connected = t->quad[q] == 3;
  });
  t->pyramid.push_back(std::move(l1));
  while (t->pyramid.back().width > 1 || t->pyramid.back().height > 1) {
    Level b;
    const Level& a = t->pyramid.back();
    merge_into(&b, a.width, a.height, [&](int x, int y, float* lo, float* hi, bool* connected) {
      const size_t s = size_t(y) * a.width + x;
      *lo = a.min_depth[s];
      *hi = a.max_depth[s];
      *connected = a.connected[s];
    });
    t->pyramid.push_back(std::move(b));
  }
}
}  // namespace

Integrator::Integrator(const VolumeGrid& grid, const std::vector<RangeImage>& images,
                       const FusionOptions& options)
    : grid_(grid), options_(options) {
  grid_.Check();
  options_.Check();
  cameras_.resize(images.size());
  for (const RangeImage& image : images) CheckRangeImage(image);  // first bad one throws
  std::vector<size_t> region_begin(images.size() + 1, 0);
  for (size_t c = 0; c < images.size(); ++c) {
    region_begin[c + 1] =
        region_begin[c] + CameraTableBytes(images[c].camera.width_px, images[c].camera.height_px,
                                           !images[c].weight.empty());
  }
  arena_ = std::make_unique<Arena>(region_begin.back());
  const int threads = options_.num_threads > 0 ? options_.num_threads : core::HardwareThreads();
  // Inconsistent samples removed first (the same for every slab: the whole instant's
  // images decide).
  std::vector<cv::Mat> consistent;
  if (options_.min_consistent_views > 0) {
    ConsistencyOptions c;
    c.min_views = options_.min_consistent_views;
    c.tolerance_mm = options_.consistency_tolerance_mm;
    c.num_threads = threads;
    consistent = KeepConsistentDepth(images, c);
  }
  // The tables of the cameras are independent: built in parallel.
  core::ParallelFor(0, int64_t(images.size()), threads, [&](int64_t c_begin, int64_t c_end) {
    for (int64_t c = c_begin; c < c_end; ++c) {
      const RangeImage& image = images[c];
      const cv::Mat& depth_mm = consistent.empty() ? image.depth_mm : consistent[c];
      const geometry::TsaiCamera cam = image.PixelCamera();
      CameraTables& t = cameras_[c];
      TableRegion region(arena_->start() + region_begin[c], region_begin[c + 1] - region_begin[c]);
      t.rotation = cam.rotation;
      t.translation_mm = cam.translation_mm;
      t.q000 = cam.rotation * grid_.VoxelCentreMm(0, 0, 0) + cam.translation_mm;
      t.ex = cam.rotation.col(0) * grid_.voxel_size_mm;
      t.ey = cam.rotation.col(1) * grid_.voxel_size_mm;
      t.ez = cam.rotation.col(2) * grid_.voxel_size_mm;
      t.width = cam.width_px;
      t.height = cam.height_px;
      t.fx_px = static_cast<float>(cam.focal_mm * cam.sx / cam.sensor.dpx_mm());
      t.fy_px = static_cast<float>(cam.focal_mm / cam.sensor.dpy_mm());
      t.cx_px = static_cast<float>(cam.cx_px);
      t.cy_px = static_cast<float>(cam.cy_px);
      // Frustum and the largest radius: undistort the image border one pixel outside.
      t.xn_min = t.yn_min = std::numeric_limits<double>::max();
      t.xn_max = t.yn_max = std::numeric_limits<double>::lowest();
      double rn2_max = 0.0;
      const Eigen::Matrix3d k_inv = cam.K().inverse();
      auto visit = [&](double x, double y) {
        const Eigen::Vector2d u = cam.UndistortPixel(Eigen::Vector2d(x, y));
        const Eigen::Vector3d n = k_inv * Eigen::Vector3d(u.x(), u.y(), 1.0);
        t.xn_min = std::min(t.xn_min, n.x());
        t.xn_max = std::max(t.xn_max, n.x());
        t.yn_min = std::min(t.yn_min, n.y());
        t.yn_max = std::max(t.yn_max, n.y());
        rn2_max = std::max(rn2_max, n.x() * n.x() + n.y() * n.y());
      };
      const int w = t.width, h = t.height;
      for (int x = -1; x <= w; ++x) {
        visit(x, -1);
        visit(x, h);
      }
      for (int y = -1; y <= h; ++y) {
        visit(-1, y);
        visit(w, y);
      }
      // lambda(rn^2): distorted / undistorted radius, tabulated in rn^2 (smooth, so a
      // linear table of 1024 entries is accurate to far below a pixel).
      t.rn2_max = static_cast<float>(rn2_max * 1.02);
      t.lut_scale = (kLutSize - 1) / t.rn2_max;
      t.lambda = region.Take<float>(kLutSize);
      for (int e = 0; e < kLutSize; ++e) {
        const double rn2 = double(e) / (kLutSize - 1) * t.rn2_max;
        const double ru = cam.focal_mm * std::sqrt(rn2);
        double rd = ru;
        geometry::DistortedRadiusMm(ru, cam.kappa1_per_mm2, &rd);
        t.lambda[e] = ru > 0.0 ? static_cast<float>(rd / ru) : 1.0f;
      }
      bool up = true, down = true;
      for (int e = 1; e < kLutSize; ++e) {
        up = up && t.lambda[e] >= t.lambda[e - 1];
        down = down && t.lambda[e] <= t.lambda[e - 1];
      }
      t.lambda_monotonic = up || down;
      t.lambda_pair = region.Take<float>(2 * kLutSize);
      for (int e = 0; e < kLutSize; ++e) {
        t.lambda_pair[2 * e] = t.lambda[e];
        t.lambda_pair[2 * e + 1] = t.lambda[std::min(e + 1, kLutSize - 1)];
      }
      const DistortionPolynomial poly = FitDistortionPolynomial(cam, t.rn2_max);
      if (poly.usable) {
        t.lambda_poly = true;
        std::copy(std::begin(poly.c), std::end(poly.c), t.lambda_c);
        t.poly_scale = 1.0f / t.rn2_max;
        // Twice the polynomial's error (once for the voxels' factor, once for the bound
        // at the block's ends), and the rounding of evaluating it in double there.
        t.lambda_slack = 2 * poly.max_error + 1e-6;
      }
      // Inverse depths and the tessellation (seed §3: no triangle across a jump).
      t.inv_depth = region.Take<float>(size_t(w) * h);
      for (int y = 0; y < h; ++y) {
        const float* row = depth_mm.ptr<float>(y);
        for (int x = 0; x < w; ++x)
          t.inv_depth[size_t(y) * w + x] = row[x] > 0 ? 1.0f / row[x] : 0.0f;
      }
      if (!image.weight.empty()) {
        t.weight = region.Take<float>(size_t(w) * h);
        for (int y = 0; y < h; ++y) {
          const float* row = image.weight.ptr<float>(y);
          std::copy(row, row + w, t.weight.begin() + size_t(y) * w);
        }
      }
      const float ratio = static_cast<float>(options_.max_depth_jump_ratio);
      const float inf = std::numeric_limits<float>::infinity();
      const size_t quads = size_t(std::max(w - 1, 0)) * std::max(h - 1, 0) + 3;
      t.quad = region.Take<uint8_t>(quads);
      t.quad_range = region.Take<float>(2 * quads);
      for (size_t q = quads - 3; q < quads; ++q) {  // the unused entries at the end
        t.quad[q] = 0;
        t.quad_range[2 * q] = inf;
        t.quad_range[2 * q + 1] = -inf;
      }
      // Without branches (a depth map's valid/invalid pattern defeats prediction): a
      // triangle is connected when its three depths are valid and differ by at most
      // `ratio` of the least; min and max are exact, so their order does not matter.
      for (int y = 0; y + 1 < h; ++y) {
        const float* r0 = depth_mm.ptr<float>(y);
        const float* r1 = depth_mm.ptr<float>(y + 1);
        uint8_t* quad_row = t.quad.data() + size_t(y) * (w - 1);
        float* range_row = t.quad_range.data() + 2 * size_t(y) * (w - 1);
        for (int x = 0; x + 1 < w; ++x) {
          const float a = r0[x], b = r0[x + 1], c = r1[x], d = r1[x + 1];
          const bool va = a > 0, vb = b > 0, vc = c > 0, vd = d > 0;
          const float ad_lo = std::min(a, d), ad_hi = std::max(a, d);
          const float ulo = std::min(ad_lo, b), uhi = std::max(ad_hi, b);  // (0,0) (1,0) (1,1)
          const float llo = std::min(ad_lo, c), lhi = std::max(ad_hi, c);  // (0,0) (0,1) (1,1)
          const uint32_t q = uint32_t(va & vd & vb & (uhi - ulo <= ratio * ulo)) |
                             uint32_t(va & vd & vc & (lhi - llo <= ratio * llo)) << 1;
          quad_row[x] = uint8_t(q);
          const float lo =
              std::min(std::min(va ? a : inf, vb ? b : inf), std::min(vc ? c : inf, vd ? d : inf));
          const float hi = std::max(std::max(va ? a : -inf, vb ? b : -inf),
                                    std::max(vc ? c : -inf, vd ? d : -inf));
          uint32_t bits;
          std::memcpy(&bits, &lo, 4);
          bits = ((bits - 4) & ~3u) | q;  // lo > 0: the pattern orders like the value
          std::memcpy(&range_row[2 * x], &bits, 4);
          range_row[2 * x + 1] = hi;
        }
      }
      const int tw = ((w - 1) >> kTileShift) + 1, th = ((h - 1) >> kTileShift) + 1;
      t.tile_w = tw;
      t.tile = region.Take<uint32_t>(size_t(tw) * th);
#if defined(__F16C__)
      std::vector<float> tlo(size_t(tw) * th, std::numeric_limits<float>::infinity());
      std::vector<float> thi(tlo.size(), -std::numeric_limits<float>::infinity());
      for (int y = 0; y + 1 < h; ++y) {
        for (int x = 0; x + 1 < w; ++x) {
          const size_t q = size_t(y) * (w - 1) + x;
          const size_t n = size_t(y >> kTileShift) * tw + (x >> kTileShift);
          tlo[n] = t.quad[q] == 3 ? std::min(tlo[n], t.QuadMin(q))
                                  : -std::numeric_limits<float>::infinity();
          thi[n] = std::max(thi[n], t.QuadMax(q));
        }
      }
      for (size_t n = 0; n < tlo.size(); ++n) {
        t.tile[n] = uint32_t(_cvtss_sh(tlo[n], _MM_FROUND_TO_NEG_INF)) |
                    uint32_t(_cvtss_sh(thi[n], _MM_FROUND_TO_POS_INF)) << 16;
      }
#endif
      BuildPyramid(&t, &region);
    }
  });
}

Integrator::~Integrator() = default;

namespace {

// Blocks of kBlock^3 voxels and super-blocks of kSuperXY x kSuperXY x kBlock voxels,
// aligned to the volume's absolute indices; a (super-)block's classification depends
// only on its indices, never on the slab.
constexpr int kBlock = 8;
constexpr int kSuperBlocks = 4;  // blocks per super-block along x and y
constexpr int kSuperXY = kBlock * kSuperBlocks;
constexpr int kSuperVoxels = kSuperXY * kSuperXY * kBlock;

}  // namespace

// Per thread: the accumulators of one super-block (k, j, i order). Contributions are
// split so that every path adds the same thing per voxel: `count` holds the clamped
// free-space contributions of weight 1 (uniform weights, d >= clamp), the float sums
// everything else, in camera order. The result is (sum_wd + count * clamp) /
// (sum_w + count), so a culled free-space (super-)block adds 1 to a counter instead of
// touching every voxel.
struct Integrator::Scratch {
  alignas(32) float sum_wd[kSuperVoxels];
  alignas(32) float sum_w[kSuperVoxels];
  alignas(32) int32_t count[kSuperVoxels];
  int32_t block_count[kSuperBlocks * kSuperBlocks];
  int32_t super_count = 0;
};

// Conservative test of the voxels [i0, i1] x [j0, j1] x [k0, k1] (inclusive, absolute)
// against one image (see FusionOptions::block_culling).
Integrator::BlockClass Integrator::ClassifyBlock(const CameraTables& t, int i0, int i1, int j0,
                                                 int j1, int k0, int k1) const {
  if (!options_.block_culling) return BlockClass::kExact;
  const double near = options_.min_depth_mm;
  Eigen::Vector3d q[8];
  double zmin = 1e300, zmax = -1e300;
  // The frustum is the intersection of half-spaces (z >= near and the four sides in
  // normalized undistorted coordinates); a convex block with all corners outside one
  // of them is outside.
  int outside[5] = {0, 0, 0, 0, 0};
  for (int c = 0; c < 8; ++c) {
    q[c] = t.q000 + double(c & 1 ? i1 : i0) * t.ex + double(c & 2 ? j1 : j0) * t.ey +
           double(c & 4 ? k1 : k0) * t.ez;
    zmin = std::min(zmin, q[c].z());
    zmax = std::max(zmax, q[c].z());
    outside[0] += q[c].z() <= near;
    outside[1] += q[c].x() < t.xn_min * q[c].z();
    outside[2] += q[c].x() > t.xn_max * q[c].z();
    outside[3] += q[c].y() < t.yn_min * q[c].z();
    outside[4] += q[c].y() > t.yn_max * q[c].z();
  }
  for (int h = 0; h < 5; ++h) {
    if (outside[h] == 8) return BlockClass::kSkip;
  }
  if (zmin <= near + 1.0) return BlockClass::kExact;
  // With every corner in front of the camera the block's perspective image is the
  // convex hull of the corners' images: a box [xa, xb] x [ya, yb] in normalized
  // coordinates. Distortion scales by lambda(rn^2), bounded over the box's rn^2 range.
  double xa = 1e300, xb = -1e300, ya = 1e300, yb = -1e300;
  for (int c = 0; c < 8; ++c) {
    const double xn = q[c].x() / q[c].z(), yn = q[c].y() / q[c].z();
    xa = std::min(xa, xn);
    xb = std::max(xb, xn);
    ya = std::min(ya, yn);
    yb = std::max(yb, yn);
  }
  const double rhi = std::max(xa * xa, xb * xb) + std::max(ya * ya, yb * yb);
  if (!(rhi <= t.rn2_max)) return BlockClass::kExact;  // partly beyond the field
  const double dx = xa > 0 ? xa : (xb < 0 ? -xb : 0.0), dy = ya > 0 ? ya : (yb < 0 ? -yb : 0.0);
  const double rlo = dx * dx + dy * dy;
  // Table entries the voxels may interpolate between (one entry of slack each side for
  // the float index).
  const int e0 = std::max(0, static_cast<int>(rlo * t.lut_scale) - 1);
  const int e1 = std::min(kLutSize - 1, static_cast<int>(rhi * t.lut_scale) + 2);
  double lmin, lmax;
  if (t.lambda_poly && t.lambda_monotonic) {
    // The polynomial at both ends (no table read: the tables of 51 cameras miss the
    // cache): the exact factor lies between its values there, the polynomial within
    // lambda_slack of it.
    const auto poly = [&](double rn2) {
      const double x = rn2 * t.poly_scale;
      double v = t.lambda_c[4];
      for (int c = 3; c >= 0; --c) v = v * x + t.lambda_c[c];
      return v;
    };
    const double a = poly(rlo), b = poly(rhi);
    lmin = std::min(a, b) - t.lambda_slack;
    lmax = std::max(a, b) + t.lambda_slack;
  } else if (t.lambda_monotonic) {
    lmin = std::min(t.lambda[e0], t.lambda[e1]);
    lmax = std::max(t.lambda[e0], t.lambda[e1]);
  } else {
    lmin = 1e300;
    lmax = -1e300;
    for (int e = e0; e <= e1; ++e) {
      lmin = std::min(lmin, double(t.lambda[e]));
      lmax = std::max(lmax, double(t.lambda[e]));
    }
  }
  // Pixel box: [xa, xb] * [lmin, lmax] * f + c, padded for float rounding.
  constexpr double kPad = 0.5;
  const double umin = std::min(xa * lmin, xa * lmax) * t.fx_px + t.cx_px - kPad;
  const double umax = std::max(xb * lmin, xb * lmax) * t.fx_px + t.cx_px + kPad;
  const double vmin = std::min(ya * lmin, ya * lmax) * t.fy_px + t.cy_px - kPad;
  const double vmax = std::max(yb * lmin, yb * lmax) * t.fy_px + t.cy_px + kPad;
  const int w = t.width, h = t.height;
  if (umax < 0 || vmax < 0 || umin >= w - 1 || vmin >= h - 1) return BlockClass::kSkip;
  const bool inside = umin >= 0 && vmin >= 0 && umax < w - 1 && vmax < h - 1;
  const int qx0 = std::max(0, static_cast<int>(std::floor(umin)));
  const int qy0 = std::max(0, static_cast<int>(std::floor(vmin)));
  const int qx1 = std::min(w - 2, static_cast<int>(std::floor(umax)));
  const int qy1 = std::min(h - 2, static_cast<int>(std::floor(vmax)));
  // Pyramid level where the box spans at most four cells per axis (level 0: the quads).
  int level = 0;
  while (level < int(t.pyramid.size()) &&
         ((qx1 >> level) - (qx0 >> level) > 3 || (qy1 >> level) - (qy0 >> level) > 3)) {
    ++level;
  }
  float dmin = std::numeric_limits<float>::infinity(),
        dmax = -std::numeric_limits<float>::infinity();
  bool all_connected = true;
  if (level == 0) {
    for (int cy = qy0; cy <= qy1; ++cy) {
      for (int cx = qx0; cx <= qx1; ++cx) {
        const size_t idx = size_t(cy) * (w - 1) + cx;
        dmin = std::min(dmin, t.QuadMin(idx));
        dmax = std::max(dmax, t.QuadMax(idx));
        all_connected = all_connected && t.quad[idx] == 3;
      }
    }
  } else {
    const auto& L = t.pyramid[level - 1];
    for (int cy = qy0 >> level; cy <= (qy1 >> level); ++cy) {
      for (int cx = qx0 >> level; cx <= (qx1 >> level); ++cx) {
        const size_t idx = size_t(cy) * L.width + cx;
        dmin = std::min(dmin, L.min_depth[idx]);
        dmax = std::max(dmax, L.max_depth[idx]);
        all_connected = all_connected && L.connected[idx];
      }
    }
  }
  // Every voxel's depth z is in [zmin, zmax]; its surface depth, wherever interpolated,
  // is in [dmin, dmax]; the ray scale is >= 1. Margins cover float rounding.
  if (zmin - options_.truncation_mm > double(dmax) * (1 + 1e-5) + 0.01) return BlockClass::kSkip;
  if (!std::isfinite(dmax)) return BlockClass::kSkip;  // no valid depth under the block
  if (inside && all_connected && t.weight.empty() &&
      double(dmin) * (1 - 1e-5) - zmax - 0.01 >= options_.front_clamp_mm) {
    return BlockClass::kFreeSpace;
  }
  return BlockClass::kExact;
}

namespace {

// One row of up to 8 voxels, i = ib + m for lanes m < lanes, against one camera: the
// forward mapping of seed Figure 6 (project, sample the tessellated depth map, signed
// distance along the ray). The camera-frame position is affine in i, evaluated from
// the row's start (`c0`, voxel i = 0) so that it does not depend on where a span
// starts. The scalar ExactRow is the reference; the SIMD paths (ExactRowPairAvx2, the
// AVX-512 ExactRowPair) do its operations per lane in the same order: the same bits.
struct RowParams {
  const Integrator::CameraTables* t;
  float sx, sy, sz;  // camera-frame step per voxel along i, mm
  float near, truncation, clamp;
  // The per-voxel shortcuts (whole tile, then quad depth range) that decide clamped free
  // space and far-behind voxels without interpolating; off with block culling so that a
  // test compares them with the full computation.
  bool shortcuts = true;
};

std::atomic<TableLookups> g_table_lookups{TableLookups::kAuto};

#if defined(__AVX2__) && defined(__FMA__) && defined(__F16C__)
// Table lookups of 8 lanes: hardware gathers, or scalar loads put together (kLoads).
// Both read the same elements, so the values and every result are the same; which is
// faster depends on the CPU (some run a gather of 8 as microcode slower than 8 loads),
// and GathersAreSlow() times both once per process. Every index is valid (masked-off
// lanes index 0).
template <bool kLoads>
struct Fetch {
  // base[k] for the 8 indices k.
  static inline __attribute__((always_inline)) __m256 Floats(const float* base, __m256i k) {
    if constexpr (!kLoads) {
      return _mm256_i32gather_ps(base, k, 4);
    } else {
      alignas(32) int32_t i[8];
      _mm256_store_si256(reinterpret_cast<__m256i*>(i), k);
      return _mm256_setr_ps(base[i[0]], base[i[1]], base[i[2]], base[i[3]], base[i[4]], base[i[5]],
                            base[i[6]], base[i[7]]);
    }
  }
  static inline __attribute__((always_inline)) __m256i Ints(const uint32_t* base, __m256i k) {
    if constexpr (!kLoads) {
      return _mm256_i32gather_epi32(reinterpret_cast<const int*>(base), k, 4);
    } else {
      alignas(32) int32_t i[8];
      _mm256_store_si256(reinterpret_cast<__m256i*>(i), k);
      return _mm256_setr_epi32(int(base[i[0]]), int(base[i[1]]), int(base[i[2]]), int(base[i[3]]),
                               int(base[i[4]]), int(base[i[5]]), int(base[i[6]]), int(base[i[7]]));
    }
  }
  // base[k] and base[k + 1] for the 8 indices k (with loads: one 8-byte load a lane).
  static inline __attribute__((always_inline)) void Pairs(const float* base, __m256i k,
                                                          __m256* first, __m256* second) {
    if constexpr (!kLoads) {
      *first = _mm256_i32gather_ps(base, k, 4);
      *second = _mm256_i32gather_ps(base + 1, k, 4);
    } else {
      alignas(32) int32_t i[8];
      _mm256_store_si256(reinterpret_cast<__m256i*>(i), k);
      const auto pair = [&](int a, int b) {
        int64_t x, y;
        std::memcpy(&x, base + i[a], 8);
        std::memcpy(&y, base + i[b], 8);
        return _mm_castsi128_ps(_mm_set_epi64x(y, x));
      };
      // [p0 p1 | p4 p5] and [p2 p3 | p6 p7], each pair (first, second).
      const __m256 g0 = _mm256_insertf128_ps(_mm256_castps128_ps256(pair(0, 1)), pair(4, 5), 1);
      const __m256 g1 = _mm256_insertf128_ps(_mm256_castps128_ps256(pair(2, 3)), pair(6, 7), 1);
      *first = _mm256_shuffle_ps(g0, g1, 0x88);
      *second = _mm256_shuffle_ps(g0, g1, 0xdd);
    }
  }
};

// Two rows of up to 8 voxels each, rows c0 and c1 (`rows` of them), accumulators
// `stride` floats apart: ExactRow's operations per lane in 8-lane AVX2. The rows go
// together so that their chains of dependent table lookups overlap (one row alone
// mostly waits on them); updates are applied once on the way out.
template <bool kLoads>
__attribute__((noinline)) void ExactRowPairAvx2(const RowParams& p, const float c0[3],
                                                const float c1[3], int ib, int lanes, int rows,
                                                int stride, float* sum_wd, float* sum_w,
                                                int32_t* count) {
  using F = Fetch<kLoads>;
  constexpr int R = 2;
  const Integrator::CameraTables& t = *p.t;
  const bool weighted = !t.weight.empty();
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256 zero = _mm256_setzero_ps();
  const __m256 row_active = _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(lanes), lane));
  const __m256 fi = _mm256_cvtepi32_ps(_mm256_add_epi32(_mm256_set1_epi32(ib), lane));
  const float* c[R] = {c0, c1};
  auto none = [](const __m256(&m)[R]) {
    return (_mm256_movemask_ps(m[0]) | _mm256_movemask_ps(m[1])) == 0;
  };
  __m256 z[R], xn[R], yn[R], rn2[R], ok[R];
  // Updates: count -1 where add_count, sums += (d, 1) where add_d (uniform weights), or
  // += (add_wd, add_w) (weighted).
  __m256 add_count[R] = {zero, zero}, add_d[R] = {zero, zero}, d[R] = {zero, zero};
  __m256 add_wd[R] = {zero, zero}, add_w[R] = {zero, zero};
  do {
#pragma GCC unroll 2
    for (int r = 0; r < R; ++r) {
      const __m256 x = _mm256_fmadd_ps(fi, _mm256_set1_ps(p.sx), _mm256_set1_ps(c[r][0]));
      const __m256 y = _mm256_fmadd_ps(fi, _mm256_set1_ps(p.sy), _mm256_set1_ps(c[r][1]));
      z[r] = _mm256_fmadd_ps(fi, _mm256_set1_ps(p.sz), _mm256_set1_ps(c[r][2]));
      const __m256 inv_z = _mm256_div_ps(_mm256_set1_ps(1.0f), z[r]);
      xn[r] = _mm256_mul_ps(x, inv_z), yn[r] = _mm256_mul_ps(y, inv_z);
      rn2[r] = _mm256_fmadd_ps(xn[r], xn[r], _mm256_mul_ps(yn[r], yn[r]));
      ok[r] = _mm256_and_ps(_mm256_cmp_ps(z[r], _mm256_set1_ps(p.near), _CMP_GT_OQ),
                            _mm256_cmp_ps(rn2[r], _mm256_set1_ps(t.rn2_max), _CMP_LE_OQ));
      ok[r] = _mm256_and_ps(ok[r], r < rows ? row_active : zero);
    }
    if (none(ok)) break;
    __m256 u[R], v[R], in[R];
    __m256i x0[R], y0[R];
#pragma GCC unroll 2
    for (int r = 0; r < R; ++r) {
      __m256 lambda;
      if (t.lambda_poly) {
        const __m256 x = _mm256_mul_ps(rn2[r], _mm256_set1_ps(t.poly_scale));
        lambda = _mm256_set1_ps(t.lambda_c[4]);
        for (int c = 3; c >= 0; --c) {
          lambda = _mm256_fmadd_ps(lambda, x, _mm256_set1_ps(t.lambda_c[c]));
        }
      } else {
        // min_ps returns its second operand for a NaN first one: NaN indices become the
        // cap.
        const __m256 e = _mm256_min_ps(_mm256_mul_ps(rn2[r], _mm256_set1_ps(t.lut_scale)),
                                       _mm256_set1_ps(float(kLutSize - 1) - 0.5f));
        const __m256i ei = _mm256_cvttps_epi32(e);
        __m256 l0, l1;
        F::Pairs(t.lambda.data(), ei, &l0, &l1);
        lambda =
            _mm256_fmadd_ps(_mm256_sub_ps(e, _mm256_cvtepi32_ps(ei)), _mm256_sub_ps(l1, l0), l0);
      }
      u[r] = _mm256_fmadd_ps(_mm256_mul_ps(xn[r], lambda), _mm256_set1_ps(t.fx_px),
                             _mm256_set1_ps(t.cx_px));
      v[r] = _mm256_fmadd_ps(_mm256_mul_ps(yn[r], lambda), _mm256_set1_ps(t.fy_px),
                             _mm256_set1_ps(t.cy_px));
      __m256 m = _mm256_and_ps(ok[r], _mm256_cmp_ps(u[r], zero, _CMP_GE_OQ));
      m = _mm256_and_ps(m, _mm256_cmp_ps(u[r], _mm256_set1_ps(float(t.width - 1)), _CMP_LT_OQ));
      m = _mm256_and_ps(m, _mm256_cmp_ps(v[r], zero, _CMP_GE_OQ));
      m = _mm256_and_ps(m, _mm256_cmp_ps(v[r], _mm256_set1_ps(float(t.height - 1)), _CMP_LT_OQ));
      in[r] = m;
      x0[r] = _mm256_and_si256(_mm256_cvttps_epi32(u[r]), _mm256_castps_si256(m));
      y0[r] = _mm256_and_si256(_mm256_cvttps_epi32(v[r]), _mm256_castps_si256(m));
    }
    if (none(in)) break;
    if (p.shortcuts) {
#pragma GCC unroll 2
      for (int r = 0; r < R; ++r) {
        // Whole tile decides (conservative: the tile's least lo and largest hi bound the
        // quad's, and the tests below are monotonic in them): clamped free space or
        // untouched.
        const __m256i ti = _mm256_add_epi32(
            _mm256_mullo_epi32(_mm256_srli_epi32(y0[r], kTileShift), _mm256_set1_epi32(t.tile_w)),
            _mm256_srli_epi32(x0[r], kTileShift));
        const __m256i packed = F::Ints(t.tile.data(), ti);
        const __m256i halves = _mm256_permute4x64_epi64(
            _mm256_packus_epi32(_mm256_and_si256(packed, _mm256_set1_epi32(0xffff)),
                                _mm256_srli_epi32(packed, 16)),
            0xd8);
        const __m256 tlo = _mm256_cvtph_ps(_mm256_castsi256_si128(halves));
        const __m256 thi = _mm256_cvtph_ps(_mm256_extracti128_si256(halves, 1));
        const __m256 behind =
            _mm256_cmp_ps(_mm256_add_ps(_mm256_fmsub_ps(thi, _mm256_set1_ps(1.0f + 1e-5f), z[r]),
                                        _mm256_set1_ps(0.01f)),
                          _mm256_set1_ps(-p.truncation), _CMP_LT_OQ);
        in[r] = _mm256_andnot_ps(behind, in[r]);
        if (!weighted) {
          const __m256 free = _mm256_and_ps(
              in[r],
              _mm256_cmp_ps(_mm256_sub_ps(_mm256_fmsub_ps(tlo, _mm256_set1_ps(1.0f - 1e-5f), z[r]),
                                          _mm256_set1_ps(0.01f)),
                            _mm256_set1_ps(p.clamp), _CMP_GE_OQ));
          add_count[r] = free;
          in[r] = _mm256_andnot_ps(free, in[r]);
        }
      }
      if (none(in)) break;
    }
    __m256 ax[R], ay[R], upper[R], valid[R], free_fast[R], rest[R];
    __m256i qi[R];
#pragma GCC unroll 2
    for (int r = 0; r < R; ++r) {
      ax[r] = _mm256_sub_ps(u[r], _mm256_cvtepi32_ps(x0[r]));
      ay[r] = _mm256_sub_ps(v[r], _mm256_cvtepi32_ps(y0[r]));
      qi[r] = _mm256_add_epi32(_mm256_mullo_epi32(y0[r], _mm256_set1_epi32(t.width - 1)), x0[r]);
      __m256 lo, hi;
      if constexpr (kLoads) {
        F::Pairs(t.quad_range.data(), _mm256_slli_epi32(qi[r], 1), &lo, &hi);
      } else {
        lo = F::Floats(t.quad_range.data(), _mm256_slli_epi32(qi[r], 1));
      }
      const __m256i q = _mm256_and_si256(_mm256_castps_si256(lo), _mm256_set1_epi32(3));
      upper[r] = _mm256_cmp_ps(ax[r], ay[r], _CMP_GE_OQ);
      const __m256i bit = _mm256_blendv_epi8(_mm256_set1_epi32(2), _mm256_set1_epi32(1),
                                             _mm256_castps_si256(upper[r]));
      const __m256i has = _mm256_cmpeq_epi32(_mm256_and_si256(q, bit), bit);
      valid[r] = _mm256_and_ps(in[r], _mm256_castsi256_ps(has));
      free_fast[r] =
          p.shortcuts
              ? _mm256_and_ps(
                    valid[r],
                    _mm256_cmp_ps(
                        _mm256_sub_ps(_mm256_fmsub_ps(lo, _mm256_set1_ps(1.0f - 1e-5f), z[r]),
                                      _mm256_set1_ps(0.01f)),
                        _mm256_set1_ps(p.clamp), _CMP_GE_OQ))
              : zero;
      rest[r] = _mm256_andnot_ps(free_fast[r], valid[r]);
      if (p.shortcuts && _mm256_movemask_ps(rest[r]) != 0) {
        if constexpr (!kLoads) {
          const __m256i qm = _mm256_and_si256(qi[r], _mm256_castps_si256(valid[r]));
          hi = F::Floats(t.quad_range.data() + 1, _mm256_slli_epi32(qm, 1));
        }
        const __m256 behind =
            _mm256_cmp_ps(_mm256_add_ps(_mm256_fmsub_ps(hi, _mm256_set1_ps(1.0f + 1e-5f), z[r]),
                                        _mm256_set1_ps(0.01f)),
                          _mm256_set1_ps(-p.truncation), _CMP_LT_OQ);
        rest[r] = _mm256_andnot_ps(behind, rest[r]);
      }
    }
    if (none(valid)) break;
    if (none(rest)) {
      if (!weighted) {
        for (int r = 0; r < R; ++r) add_count[r] = _mm256_or_ps(add_count[r], free_fast[r]);
        break;
      }
      if (none(free_fast)) break;  // all untouched
    }
#pragma GCC unroll 2
    for (int r = 0; r < R; ++r) {
      const __m256i p00 = _mm256_and_si256(
          _mm256_add_epi32(_mm256_mullo_epi32(y0[r], _mm256_set1_epi32(t.width)), x0[r]),
          _mm256_castps_si256(valid[r]));
      const float* id = t.inv_depth.data();
      __m256 i00, i10, i01, i11;  // the quad's corners
      F::Pairs(id, p00, &i00, &i10);
      F::Pairs(id + t.width, p00, &i01, &i11);
      const __m256 a = _mm256_blendv_ps(ay[r], ax[r], upper[r]);
      const __m256 b = _mm256_blendv_ps(ax[r], ay[r], upper[r]);
      const __m256 mid = _mm256_blendv_ps(i01, i10, upper[r]);
      const __m256 inv = _mm256_fmadd_ps(b, _mm256_sub_ps(i11, mid),
                                         _mm256_fmadd_ps(a, _mm256_sub_ps(mid, i00), i00));
      const __m256 scale = _mm256_sqrt_ps(_mm256_add_ps(_mm256_set1_ps(1.0f), rn2[r]));
      d[r] = _mm256_mul_ps(
          _mm256_sub_ps(_mm256_div_ps(_mm256_set1_ps(1.0f),
                                      _mm256_blendv_ps(_mm256_set1_ps(1.0f), inv, valid[r])),
                        z[r]),
          scale);
      const __m256 kept =
          _mm256_and_ps(valid[r], _mm256_cmp_ps(d[r], _mm256_set1_ps(-p.truncation), _CMP_GE_OQ));
      const __m256 clamp = _mm256_set1_ps(p.clamp);
      if (!weighted) {
        const __m256 free = _mm256_and_ps(kept, _mm256_cmp_ps(d[r], clamp, _CMP_GE_OQ));
        add_count[r] = _mm256_or_ps(add_count[r], free);
        add_d[r] = _mm256_andnot_ps(free, kept);
      } else {
        const float* wm = t.weight.data();
        __m256 w00, w10, w01, w11;
        F::Pairs(wm, p00, &w00, &w10);
        F::Pairs(wm + t.width, p00, &w01, &w11);
        const __m256 wmid = _mm256_blendv_ps(w01, w10, upper[r]);
        const __m256 wt = _mm256_fmadd_ps(b, _mm256_sub_ps(w11, wmid),
                                          _mm256_fmadd_ps(a, _mm256_sub_ps(wmid, w00), w00));
        add_wd[r] = _mm256_and_ps(kept, _mm256_mul_ps(wt, _mm256_min_ps(d[r], clamp)));
        add_w[r] = _mm256_and_ps(kept, wt);
      }
    }
  } while (false);
  for (int r = 0; r < rows; ++r) {
    int32_t* cr = count + r * stride;
    float* wd = sum_wd + r * stride;
    float* w = sum_w + r * stride;
    if (_mm256_movemask_ps(add_count[r]) != 0) {
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(cr),
                          _mm256_sub_epi32(_mm256_loadu_si256(reinterpret_cast<__m256i*>(cr)),
                                           _mm256_castps_si256(add_count[r])));
    }
    if (!weighted) {
      if (_mm256_movemask_ps(add_d[r]) == 0) continue;
      _mm256_storeu_ps(wd, _mm256_add_ps(_mm256_loadu_ps(wd), _mm256_and_ps(add_d[r], d[r])));
      _mm256_storeu_ps(
          w, _mm256_add_ps(_mm256_loadu_ps(w), _mm256_and_ps(add_d[r], _mm256_set1_ps(1.0f))));
    } else {
      _mm256_storeu_ps(wd, _mm256_add_ps(_mm256_loadu_ps(wd), add_wd[r]));
      _mm256_storeu_ps(w, _mm256_add_ps(_mm256_loadu_ps(w), add_w[r]));
    }
  }
}

// Whether 8 scalar loads beat one hardware gather of 8 floats on this CPU: both timed
// over the same indices, best of several rounds, once per process (about a millisecond).
[[maybe_unused]] bool GathersAreSlow() {
  static const bool slow = [] {
    std::vector<float> table(1 << 16);
    for (size_t i = 0; i < table.size(); ++i) table[i] = float(i & 1023);
    std::vector<int32_t> idx(8 * 512);
    uint32_t r = 12345;
    for (size_t k = 0; k < idx.size(); k += 8) {
      r = r * 1664525u + 1013904223u;
      const int32_t b = int32_t(r >> 17) % int32_t(table.size() - 64);
      for (int m = 0; m < 8; ++m) idx[k + m] = b + 3 * m;  // a row's spread
    }
    const auto time = [&](auto fetch) {
      double best = 1e30;
      for (int round = 0; round < 5; ++round) {
        const auto t0 = std::chrono::steady_clock::now();
        __m256 acc = _mm256_setzero_ps();
        for (size_t k = 0; k < idx.size(); k += 8) {
          const __m256i i = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(&idx[k]));
          __m256 a, b;
          fetch(i, &a, &b);
          acc = _mm256_add_ps(acc, _mm256_add_ps(a, b));
        }
        alignas(32) float sink[8];
        _mm256_store_ps(sink, acc);
        volatile float keep = sink[0];
        (void)keep;
        best = std::min(
            best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      }
      return best;
    };
    const float* base = table.data();
    const double gather =
        time([&](__m256i i, __m256* a, __m256* b) { Fetch<false>::Pairs(base, i, a, b); });
    const double loads =
        time([&](__m256i i, __m256* a, __m256* b) { Fetch<true>::Pairs(base, i, a, b); });
    return loads < gather;
  }();
  return slow;
}

#else
__attribute__((noinline)) void ExactRow(const RowParams& p, float c0x, float c0y, float c0z, int ib,
                                        int lanes, float* sum_wd, float* sum_w, int32_t* count) {
  const Integrator::CameraTables& t = *p.t;
  const int w = t.width;
  for (int m = 0; m < lanes; ++m) {
    const float fi = static_cast<float>(ib + m);
    const float x = c0x + fi * p.sx, y = c0y + fi * p.sy, z = c0z + fi * p.sz;
    const float inv_z = 1.0f / z;
    const float xn = x * inv_z, yn = y * inv_z;
    const float rn2 = xn * xn + yn * yn;
    if (!(z > p.near && rn2 <= t.rn2_max)) continue;
    float lambda;
    if (t.lambda_poly) {
      const float x = rn2 * t.poly_scale;
      lambda = t.lambda_c[4];
      for (int c = 3; c >= 0; --c) lambda = std::fma(lambda, x, t.lambda_c[c]);
    } else {
      const float e = std::min(rn2 * t.lut_scale, float(kLutSize - 1) - 0.5f);
      const int ei = static_cast<int>(e);
      lambda = std::fma(e - float(ei), t.lambda[ei + 1] - t.lambda[ei], t.lambda[ei]);
    }
    const float u = xn * lambda * t.fx_px + t.cx_px, v = yn * lambda * t.fy_px + t.cy_px;
    if (!(u >= 0.0f && u < float(t.width - 1) && v >= 0.0f && v < float(t.height - 1))) continue;
    const int x0 = static_cast<int>(u), y0 = static_cast<int>(v);
    const float ax = u - float(x0), ay = v - float(y0);
    const uint8_t q = t.quad[size_t(y0) * (w - 1) + x0];
    const bool upper = ax >= ay;
    if (!(q & (upper ? 1 : 2))) continue;
    const size_t p00 = size_t(y0) * w + x0;
    const float a = upper ? ax : ay, b = upper ? ay : ax;
    const size_t pm = upper ? p00 + 1 : p00 + w;
    const float* id = t.inv_depth.data();
    const float inv = id[p00] + a * (id[pm] - id[p00]) + b * (id[p00 + w + 1] - id[pm]);
    const float d = (1.0f / inv - z) * std::sqrt(1.0f + rn2);
    if (d < -p.truncation) continue;  // far behind the surface: untouched
    if (t.weight.empty()) {
      if (d >= p.clamp) {
        ++count[m];
      } else {
        sum_wd[m] += d;
        sum_w[m] += 1.0f;
      }
    } else {
      const float* wm = t.weight.data();
      const float wt = wm[p00] + a * (wm[pm] - wm[p00]) + b * (wm[p00 + w + 1] - wm[pm]);
      sum_wd[m] += wt * std::min(d, p.clamp);
      sum_w[m] += wt;
    }
  }
}
#endif

// Two rows of up to 8 voxels each (rows j and j + 1 of a block, `rows` of them), i = ib + m
// for m < lanes, their accumulators `stride` floats apart: one 16-lane pass where the
// machine has AVX-512 (gathers of 16 indices cost less per index than two of 8, and the
// per-call work is shared), else ExactRow per row. The per-lane arithmetic is the same
// operation sequence as ExactRow's, so the values are bit-identical.
#if DOME_FUSION_AVX512
// GCC 12's AVX-512 headers start unmasked intrinsics from an "undefined" register, which
// -Wmaybe-uninitialized reports at every use; nothing here reads an undefined lane.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
// For 16 indices `idx` (lanes not in `k` read nothing and give 0): the float pairs
// (base[2 idx], base[2 idx + 1]) as `first`, `second`, with two 8-byte gathers of 8.
// With kScale 4: base[idx], base[idx + 1] (two adjacent floats at any index).
template <int kScale = 8>
inline void GatherPairs(__m512i idx, __mmask16 k, const float* base, __m512* first,
                        __m512* second) {
  const __m512i g0 = _mm512_mask_i32gather_epi64(_mm512_setzero_si512(), __mmask8(k),
                                                 _mm512_castsi512_si256(idx), base, kScale);
  const __m512i g1 = _mm512_mask_i32gather_epi64(_mm512_setzero_si512(), __mmask8(k >> 8),
                                                 _mm512_extracti64x4_epi64(idx, 1), base, kScale);
  const __m512i even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
  const __m512i odd = _mm512_add_epi32(even, _mm512_set1_epi32(1));
  *first = _mm512_castsi512_ps(_mm512_permutex2var_epi32(g0, even, g1));
  *second = _mm512_castsi512_ps(_mm512_permutex2var_epi32(g0, odd, g1));
}

__attribute__((noinline)) void ExactRowPair(const RowParams& p, const float c0[3],
                                            const float c1[3], int ib, int lanes, int rows,
                                            int stride, float* sum_wd, float* sum_w,
                                            int32_t* count) {
  const Integrator::CameraTables& t = *p.t;
  const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5, 6, 7);
  const __mmask16 row_mask = static_cast<__mmask16>((1u << lanes) - 1u);
  const __mmask16 active = static_cast<__mmask16>(row_mask | (rows > 1 ? row_mask << 8 : 0));
  const __mmask16 second = 0xff00;
  const __m512 fi = _mm512_cvtepi32_ps(_mm512_add_epi32(_mm512_set1_epi32(ib), lane));
  const __m512 bx = _mm512_mask_blend_ps(second, _mm512_set1_ps(c0[0]), _mm512_set1_ps(c1[0]));
  const __m512 by = _mm512_mask_blend_ps(second, _mm512_set1_ps(c0[1]), _mm512_set1_ps(c1[1]));
  const __m512 bz = _mm512_mask_blend_ps(second, _mm512_set1_ps(c0[2]), _mm512_set1_ps(c1[2]));
  const __m512 x = _mm512_fmadd_ps(fi, _mm512_set1_ps(p.sx), bx);
  const __m512 y = _mm512_fmadd_ps(fi, _mm512_set1_ps(p.sy), by);
  const __m512 z = _mm512_fmadd_ps(fi, _mm512_set1_ps(p.sz), bz);
  const __m512 inv_z = _mm512_div_ps(_mm512_set1_ps(1.0f), z);
  const __m512 xn = _mm512_mul_ps(x, inv_z), yn = _mm512_mul_ps(y, inv_z);
  const __m512 rn2 = _mm512_fmadd_ps(xn, xn, _mm512_mul_ps(yn, yn));
  // Accumulator updates, applied once on the way out.
  __mmask16 add_count = 0;
  __mmask16 add_d = 0;  // unweighted: sum_wd += d, sum_w += 1
  __m512 d = _mm512_setzero_ps();
  __m512 add_wd = _mm512_setzero_ps(), add_w = _mm512_setzero_ps();  // weighted
  bool weighted_add = false;
  do {
    __mmask16 ok = _mm512_cmp_ps_mask(z, _mm512_set1_ps(p.near), _CMP_GT_OQ) &
                   _mm512_cmp_ps_mask(rn2, _mm512_set1_ps(t.rn2_max), _CMP_LE_OQ) & active;
    if (ok == 0) break;
    __m512 lambda;
    if (t.lambda_poly) {
      const __m512 x = _mm512_mul_ps(rn2, _mm512_set1_ps(t.poly_scale));
      lambda = _mm512_set1_ps(t.lambda_c[4]);
      for (int c = 3; c >= 0; --c) {
        lambda = _mm512_fmadd_ps(lambda, x, _mm512_set1_ps(t.lambda_c[c]));
      }
    } else {
      // min_ps returns its second operand for a NaN first one: NaN indices become the cap.
      const __m512 e = _mm512_min_ps(_mm512_mul_ps(rn2, _mm512_set1_ps(t.lut_scale)),
                                     _mm512_set1_ps(float(kLutSize - 1) - 0.5f));
      const __m512i ei = _mm512_cvttps_epi32(e);
      __m512 l0, l1;
      GatherPairs(ei, 0xffff, t.lambda_pair.data(), &l0, &l1);
      lambda = _mm512_fmadd_ps(_mm512_sub_ps(e, _mm512_cvtepi32_ps(ei)), _mm512_sub_ps(l1, l0), l0);
    }
    const __m512 u = _mm512_fmadd_ps(_mm512_mul_ps(xn, lambda), _mm512_set1_ps(t.fx_px),
                                     _mm512_set1_ps(t.cx_px));
    const __m512 v = _mm512_fmadd_ps(_mm512_mul_ps(yn, lambda), _mm512_set1_ps(t.fy_px),
                                     _mm512_set1_ps(t.cy_px));
    const __m512 zero = _mm512_setzero_ps();
    __mmask16 in = ok & _mm512_cmp_ps_mask(u, zero, _CMP_GE_OQ) &
                   _mm512_cmp_ps_mask(u, _mm512_set1_ps(float(t.width - 1)), _CMP_LT_OQ) &
                   _mm512_cmp_ps_mask(v, zero, _CMP_GE_OQ) &
                   _mm512_cmp_ps_mask(v, _mm512_set1_ps(float(t.height - 1)), _CMP_LT_OQ);
    if (in == 0) break;
    const __m512i x0 = _mm512_maskz_cvttps_epi32(in, u);
    const __m512i y0 = _mm512_maskz_cvttps_epi32(in, v);
    if (p.shortcuts) {
      // Whole tile decides (see ExactRow).
      const __m512i ti = _mm512_add_epi32(
          _mm512_mullo_epi32(_mm512_srli_epi32(y0, kTileShift), _mm512_set1_epi32(t.tile_w)),
          _mm512_srli_epi32(x0, kTileShift));
      const __m512i packed = _mm512_i32gather_epi32(ti, t.tile.data(), 4);
      const __m512 tlo = _mm512_cvtph_ps(_mm512_cvtepi32_epi16(packed));
      const __m512 thi = _mm512_cvtph_ps(_mm512_cvtepi32_epi16(_mm512_srli_epi32(packed, 16)));
      const __mmask16 behind =
          _mm512_cmp_ps_mask(_mm512_add_ps(_mm512_fmsub_ps(thi, _mm512_set1_ps(1.0f + 1e-5f), z),
                                           _mm512_set1_ps(0.01f)),
                             _mm512_set1_ps(-p.truncation), _CMP_LT_OQ);
      in &= ~behind;
      if (t.weight.empty()) {
        const __mmask16 free =
            in &
            _mm512_cmp_ps_mask(_mm512_sub_ps(_mm512_fmsub_ps(tlo, _mm512_set1_ps(1.0f - 1e-5f), z),
                                             _mm512_set1_ps(0.01f)),
                               _mm512_set1_ps(p.clamp), _CMP_GE_OQ);
        add_count |= free;
        in &= ~free;
      }
      if (in == 0) break;
    }
    const __m512 ax = _mm512_sub_ps(u, _mm512_cvtepi32_ps(x0));
    const __m512 ay = _mm512_sub_ps(v, _mm512_cvtepi32_ps(y0));
    const __m512i qi = _mm512_add_epi32(_mm512_mullo_epi32(y0, _mm512_set1_epi32(t.width - 1)), x0);
    __m512 lo, hi;  // hi is read only with the shortcuts
    GatherPairs(qi, in, t.quad_range.data(), &lo, &hi);
    const __m512i q = _mm512_and_si512(_mm512_castps_si512(lo), _mm512_set1_epi32(3));
    // Upper triangle (bit 0) where ax >= ay, lower (bit 1) otherwise.
    const __mmask16 upper = _mm512_cmp_ps_mask(ax, ay, _CMP_GE_OQ);
    const __m512i bit = _mm512_mask_blend_epi32(upper, _mm512_set1_epi32(2), _mm512_set1_epi32(1));
    __mmask16 valid = in & _mm512_cmpeq_epi32_mask(_mm512_and_si512(q, bit), bit);
    if (valid == 0) break;
    const __mmask16 free_fast =
        p.shortcuts
            ? static_cast<__mmask16>(
                  valid & _mm512_cmp_ps_mask(
                              _mm512_sub_ps(_mm512_fmsub_ps(lo, _mm512_set1_ps(1.0f - 1e-5f), z),
                                            _mm512_set1_ps(0.01f)),
                              _mm512_set1_ps(p.clamp), _CMP_GE_OQ))
            : __mmask16{0};
    __mmask16 rest = valid & ~free_fast;
    if (p.shortcuts && rest != 0) {
      const __mmask16 behind =
          _mm512_cmp_ps_mask(_mm512_add_ps(_mm512_fmsub_ps(hi, _mm512_set1_ps(1.0f + 1e-5f), z),
                                           _mm512_set1_ps(0.01f)),
                             _mm512_set1_ps(-p.truncation), _CMP_LT_OQ);
      rest &= ~behind;
    }
    if (rest == 0) {
      if (t.weight.empty()) {
        add_count |= free_fast;
        break;
      }
      if (free_fast == 0) break;  // all untouched
    }
    const __m512i p00 = _mm512_add_epi32(_mm512_mullo_epi32(y0, _mm512_set1_epi32(t.width)), x0);
    const float* id = t.inv_depth.data();
    __m512 i00, i10, i01, i11;  // the quad's corners, two 8-byte loads per lane
    GatherPairs<4>(p00, valid, id, &i00, &i10);
    GatherPairs<4>(p00, valid, id + t.width, &i01, &i11);
    // Upper: i00 + ax (i10 - i00) + ay (i11 - i10); lower: i00 + ay (i01 - i00) + ax (i11 - i01).
    const __m512 a = _mm512_mask_blend_ps(upper, ay, ax), b = _mm512_mask_blend_ps(upper, ax, ay);
    const __m512 mid = _mm512_mask_blend_ps(upper, i01, i10);
    const __m512 inv = _mm512_fmadd_ps(b, _mm512_sub_ps(i11, mid),
                                       _mm512_fmadd_ps(a, _mm512_sub_ps(mid, i00), i00));
    const __m512 scale = _mm512_sqrt_ps(_mm512_add_ps(_mm512_set1_ps(1.0f), rn2));
    d = _mm512_mul_ps(
        _mm512_sub_ps(_mm512_div_ps(_mm512_set1_ps(1.0f),
                                    _mm512_mask_blend_ps(valid, _mm512_set1_ps(1.0f), inv)),
                      z),
        scale);
    valid &= _mm512_cmp_ps_mask(d, _mm512_set1_ps(-p.truncation), _CMP_GE_OQ);
    const __m512 clamp = _mm512_set1_ps(p.clamp);
    if (t.weight.empty()) {
      const __mmask16 free = valid & _mm512_cmp_ps_mask(d, clamp, _CMP_GE_OQ);
      add_count |= free;
      add_d = valid & ~free;
    } else {
      const float* wm = t.weight.data();
      const __m512 w00 = _mm512_mask_i32gather_ps(zero, valid, p00, wm, 4);
      const __m512 w10 = _mm512_mask_i32gather_ps(zero, valid, p00, wm + 1, 4);
      const __m512 w01 = _mm512_mask_i32gather_ps(zero, valid, p00, wm + t.width, 4);
      const __m512 w11 = _mm512_mask_i32gather_ps(zero, valid, p00, wm + t.width + 1, 4);
      const __m512 wmid = _mm512_mask_blend_ps(upper, w01, w10);
      const __m512 wt = _mm512_fmadd_ps(b, _mm512_sub_ps(w11, wmid),
                                        _mm512_fmadd_ps(a, _mm512_sub_ps(wmid, w00), w00));
      add_wd = _mm512_maskz_mov_ps(valid, _mm512_mul_ps(wt, _mm512_min_ps(d, clamp)));
      add_w = _mm512_maskz_mov_ps(valid, wt);
      weighted_add = true;
    }
  } while (false);
  // Rows are 8 lanes each, `stride` apart in the accumulators.
  auto load2 = [stride](const float* ptr) {
    return _mm512_insertf32x8(_mm512_castps256_ps512(_mm256_loadu_ps(ptr)),
                              _mm256_loadu_ps(ptr + stride), 1);
  };
  auto store2 = [stride](float* ptr, __m512 v) {
    _mm256_storeu_ps(ptr, _mm512_castps512_ps256(v));
    _mm256_storeu_ps(ptr + stride, _mm512_extractf32x8_ps(v, 1));
  };
  if (add_count != 0) {
    const __m512 c = _mm512_castsi512_ps(
        _mm512_add_epi32(_mm512_castps_si512(load2(reinterpret_cast<const float*>(count))),
                         _mm512_maskz_mov_epi32(add_count, _mm512_set1_epi32(1))));
    store2(reinterpret_cast<float*>(count), c);
  }
  if (add_d != 0) {
    store2(sum_wd, _mm512_add_ps(load2(sum_wd), _mm512_maskz_mov_ps(add_d, d)));
    store2(sum_w, _mm512_add_ps(load2(sum_w), _mm512_maskz_mov_ps(add_d, _mm512_set1_ps(1.0f))));
  } else if (weighted_add) {
    store2(sum_wd, _mm512_add_ps(load2(sum_wd), add_wd));
    store2(sum_w, _mm512_add_ps(load2(sum_w), add_w));
  }
}
#pragma GCC diagnostic pop
#else
void ExactRowPair(const RowParams& p, const float c0[3], const float c1[3], int ib, int lanes,
                  int rows, int stride, float* sum_wd, float* sum_w, int32_t* count) {
#if defined(__AVX2__) && defined(__FMA__) && defined(__F16C__)
  const TableLookups mode = g_table_lookups.load(std::memory_order_relaxed);
  const bool loads =
      mode == TableLookups::kLoads || (mode == TableLookups::kAuto && GathersAreSlow());
  (loads ? ExactRowPairAvx2<true> : ExactRowPairAvx2<false>)(p, c0, c1, ib, lanes, rows, stride,
                                                             sum_wd, sum_w, count);
#else
  ExactRow(p, c0[0], c0[1], c0[2], ib, lanes, sum_wd, sum_w, count);
  if (rows > 1) {
    ExactRow(p, c1[0], c1[1], c1[2], ib, lanes, sum_wd + stride, sum_w + stride, count + stride);
  }
#endif
}
#endif

}  // namespace

// Super-block (si, sj, sk) clipped to the slab's planes [k0, k1): every camera in its
// given order, classified per super-block, then per block, then voxel rows.
void Integrator::IntegrateSuperBlock(int si, int sj, int sk, int k0, int k1, Slab* slab,
                                     Scratch* s) const {
  const int nx = grid_.nx, ny = grid_.ny, nz = grid_.nz;
  const int ib = si * kSuperXY, ie = std::min(nx, ib + kSuperXY);
  const int jb = sj * kSuperXY, je = std::min(ny, jb + kSuperXY);
  const int kb_abs = sk * kBlock, ke_abs = std::min(nz, kb_abs + kBlock);
  const int kb = std::max(k0, kb_abs), ke = std::min(k1, ke_abs);
  // Local layout: (k - kb, j - jb, i - ib), rows of kSuperXY.
  const int planes = ke - kb;
  const int local = planes * kSuperXY * kSuperXY;
  std::fill(s->sum_wd, s->sum_wd + local, 0.0f);
  std::fill(s->sum_w, s->sum_w + local, 0.0f);
  std::fill(s->count, s->count + local, 0);
  std::fill(std::begin(s->block_count), std::end(s->block_count), 0);
  s->super_count = 0;
  RowParams p;
  p.near = static_cast<float>(options_.min_depth_mm);
  p.truncation = static_cast<float>(options_.truncation_mm);
  p.clamp = static_cast<float>(options_.front_clamp_mm);
  p.shortcuts = options_.block_culling;
  for (const CameraTables& t : cameras_) {
    const BlockClass cls = ClassifyBlock(t, ib, ie - 1, jb, je - 1, kb_abs, ke_abs - 1);
    if (cls == BlockClass::kSkip) continue;
    if (cls == BlockClass::kFreeSpace) {
      ++s->super_count;
      continue;
    }
    p.t = &t;
    p.sx = static_cast<float>(t.ex.x());
    p.sy = static_cast<float>(t.ex.y());
    p.sz = static_cast<float>(t.ex.z());
    for (int bj = 0; bj < kSuperBlocks && jb + bj * kBlock < je; ++bj) {
      const int bj0 = jb + bj * kBlock, bj1 = std::min(je, bj0 + kBlock);
      for (int bi = 0; bi < kSuperBlocks && ib + bi * kBlock < ie; ++bi) {
        const int bi0 = ib + bi * kBlock, bi1 = std::min(ie, bi0 + kBlock);
        const BlockClass bcls = ClassifyBlock(t, bi0, bi1 - 1, bj0, bj1 - 1, kb_abs, ke_abs - 1);
        if (bcls == BlockClass::kSkip) continue;
        if (bcls == BlockClass::kFreeSpace) {
          ++s->block_count[bj * kSuperBlocks + bi];
          continue;
        }
        for (int k = kb; k < ke; ++k) {
          for (int j = bj0; j < bj1; j += 2) {
            // Rows j and j + 1 (blocks start at even j, so both lie in one plane of
            // the scratch); the start of each row is computed as for a single row.
            const Eigen::Vector3d r0 = t.q000 + double(j) * t.ey + double(k) * t.ez;
            const Eigen::Vector3d r1 = t.q000 + double(j + 1) * t.ey + double(k) * t.ez;
            const float c0[3] = {float(r0.x()), float(r0.y()), float(r0.z())};
            const float c1[3] = {float(r1.x()), float(r1.y()), float(r1.z())};
            const int o = ((k - kb) * kSuperXY + (j - jb)) * kSuperXY + (bi0 - ib);
            ExactRowPair(p, c0, c1, bi0, bi1 - bi0, std::min(2, bj1 - j), kSuperXY, s->sum_wd + o,
                         s->sum_w + o, s->count + o);
          }
        }
      }
    }
  }
  const float clamp = p.clamp;
  const float min_weight = static_cast<float>(options_.min_weight);
  for (int k = kb; k < ke; ++k) {
    for (int j = jb; j < je; ++j) {
      const int o = ((k - kb) * kSuperXY + (j - jb)) * kSuperXY;
      const size_t out = (size_t(k - slab->k0) * ny + j) * nx + ib;
      const int32_t* bc = s->block_count + ((j - jb) / kBlock) * kSuperBlocks;
#if DOME_FUSION_AVX512
#pragma GCC diagnostic push  // as for ExactRowPair
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
      // The scalar loop below, 16 voxels (two blocks) at a time, the same operations.
      for (int m = 0; m < ie - ib; m += 16) {
        const int lanes = std::min(16, ie - ib - m);
        const __mmask16 store = lanes == 16 ? __mmask16(0xffff) : __mmask16((1u << lanes) - 1u);
        const __m512i blocks = _mm512_mask_blend_epi32(0xff00, _mm512_set1_epi32(bc[m / kBlock]),
                                                       _mm512_set1_epi32(bc[m / kBlock + 1]));
        const __m512i cnt =
            _mm512_add_epi32(_mm512_add_epi32(_mm512_set1_epi32(s->super_count), blocks),
                             _mm512_loadu_si512(s->count + o + m));
        const __m512 n = _mm512_cvtepi32_ps(cnt);
        const __m512 w = _mm512_add_ps(_mm512_loadu_ps(s->sum_w + o + m), n);
        const __mmask16 kept = _mm512_cmp_ps_mask(w, _mm512_setzero_ps(), _CMP_GT_OQ) &
                               _mm512_cmp_ps_mask(w, _mm512_set1_ps(min_weight), _CMP_GE_OQ);
        const __m512 num = _mm512_add_ps(_mm512_loadu_ps(s->sum_wd + o + m),
                                         _mm512_mul_ps(n, _mm512_set1_ps(clamp)));
        _mm512_mask_storeu_ps(slab->weight.data() + out + m, store, _mm512_maskz_mov_ps(kept, w));
        _mm512_mask_storeu_ps(slab->distance_mm.data() + out + m, store,
                              _mm512_maskz_div_ps(kept, num, w));
      }
#pragma GCC diagnostic pop
#elif defined(__AVX2__) && defined(__FMA__)
      // The scalar loop below, 8 voxels (one block) at a time, the same operations. A
      // block cut by the volume's edge goes through a padded copy: masked stores are
      // microcode on some CPUs, slower than the rest of the loop together.
      for (int m = 0; m < ie - ib; m += 8) {
        const int lanes = std::min(8, ie - ib - m);
        alignas(32) int32_t count[8] = {};
        alignas(32) float sum_w[8] = {}, sum_wd[8] = {}, weight[8], distance[8];
        const bool whole = lanes == 8;
        if (!whole) {
          std::memcpy(count, s->count + o + m, sizeof(int32_t) * lanes);
          std::memcpy(sum_w, s->sum_w + o + m, sizeof(float) * lanes);
          std::memcpy(sum_wd, s->sum_wd + o + m, sizeof(float) * lanes);
        }
        const int32_t* c_in = whole ? s->count + o + m : count;
        const float* w_in = whole ? s->sum_w + o + m : sum_w;
        const float* wd_in = whole ? s->sum_wd + o + m : sum_wd;
        float* w_out = whole ? slab->weight.data() + out + m : weight;
        float* d_out = whole ? slab->distance_mm.data() + out + m : distance;
        const __m256i cnt =
            _mm256_add_epi32(_mm256_set1_epi32(s->super_count + bc[m / kBlock]),
                             _mm256_loadu_si256(reinterpret_cast<const __m256i*>(c_in)));
        const __m256 n = _mm256_cvtepi32_ps(cnt);
        const __m256 w = _mm256_add_ps(_mm256_loadu_ps(w_in), n);
        const __m256 kept = _mm256_and_ps(_mm256_cmp_ps(w, _mm256_setzero_ps(), _CMP_GT_OQ),
                                          _mm256_cmp_ps(w, _mm256_set1_ps(min_weight), _CMP_GE_OQ));
        const __m256 num =
            _mm256_add_ps(_mm256_loadu_ps(wd_in), _mm256_mul_ps(n, _mm256_set1_ps(clamp)));
        // Lanes not kept may divide by zero; their results are masked to 0.
        _mm256_storeu_ps(w_out, _mm256_and_ps(kept, w));
        _mm256_storeu_ps(d_out, _mm256_and_ps(kept, _mm256_div_ps(num, w)));
        if (!whole) {
          std::memcpy(slab->weight.data() + out + m, weight, sizeof(float) * lanes);
          std::memcpy(slab->distance_mm.data() + out + m, distance, sizeof(float) * lanes);
        }
      }
#else
      for (int m = 0; m < ie - ib; ++m) {
        const float n = float(s->super_count + bc[m / kBlock] + s->count[o + m]);
        const float w = s->sum_w[o + m] + n;
        const bool kept = w > 0.0f && w >= min_weight;
        slab->weight[out + m] = kept ? w : 0.0f;
        slab->distance_mm[out + m] = kept ? (s->sum_wd[o + m] + n * clamp) / w : 0.0f;
      }
#endif
    }
  }
}

Slab Integrator::IntegrateSlab(int k0, int k1) const {
  Slab slab;
  IntegrateSlab(k0, k1, &slab);
  return slab;
}

void Integrator::IntegrateSlab(int k0, int k1, Slab* slab, int num_threads) const {
  grid_.CheckSlab(k0, k1);
  slab->k0 = k0;
  slab->k1 = k1;
  slab->nx = grid_.nx;
  slab->ny = grid_.ny;
  const size_t voxels = size_t(k1 - k0) * grid_.ny * grid_.nx;
  slab->distance_mm.resize(voxels);  // every value is written below
  slab->weight.resize(voxels);
  // Work items: the super-blocks meeting the slab, handed out dynamically (work differs
  // a lot between them); each voxel's value depends only on its indices, so the
  // schedule does not change the result.
  const int sk0 = k0 / kBlock, sk1 = (k1 - 1) / kBlock + 1;
  const int sin = (grid_.nx + kSuperXY - 1) / kSuperXY;
  const int sjn = (grid_.ny + kSuperXY - 1) / kSuperXY;
  const int64_t per_layer = int64_t(sin) * sjn;
  const int64_t items = int64_t(sk1 - sk0) * per_layer;
  if (num_threads <= 0) num_threads = options_.num_threads;
  const int threads = static_cast<int>(std::max<int64_t>(
      1, std::min<int64_t>(num_threads > 0 ? num_threads : core::HardwareThreads(), items)));
  std::atomic<int64_t> next{0};
  core::ParallelFor(0, threads, threads, [&](int64_t, int64_t) {
    auto scratch = std::make_unique<Scratch>();
    for (int64_t item; (item = next.fetch_add(1)) < items;) {
      const int sk = sk0 + static_cast<int>(item / per_layer);
      const int rest = static_cast<int>(item % per_layer);
      IntegrateSuperBlock(rest % sin, rest / sin, sk, k0, k1, slab, scratch.get());
    }
  });
}

DistortionPolynomial FitDistortionPolynomial(const geometry::TsaiCamera& camera, double rn2_max) {
  DistortionPolynomial p;
  const auto exact = [&](double x) {
    const double ru = camera.focal_mm * std::sqrt(x * rn2_max);
    double rd = ru;
    if (!geometry::DistortedRadiusMm(ru, camera.kappa1_per_mm2, &rd)) return std::nan("");
    return ru > 0.0 ? rd / ru : 1.0;
  };
  if (!(rn2_max > 0.0)) return p;
  if (camera.kappa1_per_mm2 == 0.0) {  // lambda = 1
    p.usable = true;
    return p;
  }
  // Least squares on 1024 points of [0, 1], in double.
  constexpr int kPoints = 1024, kTerms = 5;
  Eigen::Matrix<double, kPoints, kTerms> a;
  Eigen::Matrix<double, kPoints, 1> b;
  for (int i = 0; i < kPoints; ++i) {
    const double x = double(i) / (kPoints - 1);
    b(i) = exact(x);
    if (!std::isfinite(b(i))) return p;  // beyond the distortion's root: keep the table
    double xk = 1.0;
    for (int k = 0; k < kTerms; ++k, xk *= x) a(i, k) = xk;
  }
  const Eigen::Matrix<double, kTerms, 1> c = a.colPivHouseholderQr().solve(b);
  for (int k = 0; k < kTerms; ++k) p.c[k] = static_cast<float>(c(k));
  // The error of what the kernel computes (float Horner with fused multiply-adds),
  // between and at the fitting points.
  for (int i = 0; i <= 4 * kPoints; ++i) {
    const float x = float(double(i) / (4 * kPoints));
    float v = p.c[4];
    for (int k = 3; k >= 0; --k) v = std::fma(v, x, p.c[k]);
    p.max_error = std::max(p.max_error, std::abs(double(v) - exact(double(x))));
  }
  p.usable = p.max_error < 3e-7;
  return p;
}

void SetTableLookups(TableLookups lookups) { g_table_lookups.store(lookups); }

void FuseVolume(const VolumeGrid& grid, const std::vector<RangeImage>& images,
                const FusionOptions& options, int planes_per_slab,
                const std::function<void(const Slab&)>& consume) {
  core::Require(planes_per_slab > 0, "fusion: planes_per_slab",
                "must be a positive plane count, got " + std::to_string(planes_per_slab));
  Integrator integrator(grid, images, options);
  for (int k0 = 0; k0 < grid.nz; k0 += planes_per_slab) {
    consume(integrator.IntegrateSlab(k0, std::min(grid.nz, k0 + planes_per_slab)));
  }
}

}  // namespace dome::fusion
