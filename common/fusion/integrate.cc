#include "fusion/integrate.h"

#include <Eigen/LU>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/parallel_for.h"
#include "io/depth_tiff.h"

namespace dome::fusion {
namespace {

constexpr int kLutSize = 1024;  // entries of the distortion table lambda(rn^2)

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
}

void CheckRangeImage(const RangeImage& image) {
  const std::string where =
      image.where.empty() ? "range image of camera " + image.camera.id : image.where;
  image.camera.Check(where + ": camera");
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

// Everything the hot loop needs about one camera, in float, contiguous.
// (BuildPyramid is defined after the struct.)
struct Integrator::CameraTables {
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation_mm;
  float fx_px = 0, fy_px = 0, cx_px = 0, cy_px = 0;       // normalized -> pixel (times lambda)
  float rn2_max = 0;                                      // largest tabulated (x/z)^2 + (y/z)^2
  float lut_scale = 0;                                    // (kLutSize - 1) / rn2_max
  std::vector<float> lambda;                              // distortion factor over rn^2
  double xn_min = 0, xn_max = 0, yn_min = 0, yn_max = 0;  // frustum, normalized coords
  int width = 0, height = 0;
  std::vector<float> inv_depth;  // 1 / depth, 0 where invalid; width x height
  std::vector<float> weight;     // empty = uniform
  std::vector<uint8_t> quad;     // (width-1) x (height-1): bit 0 upper, bit 1 lower triangle
  // Min/max depth pyramid over the quads for block culling. Level 0: one cell per quad
  // (min over its 4 depths, +inf unless all valid; max over its valid depths, -inf if
  // none; connected = both triangles exist); level l + 1 merges 2x2 cells of level l.
  struct Level {
    int width = 0, height = 0;
    std::vector<float> min_depth, max_depth;
    std::vector<uint8_t> connected;
  };
  std::vector<Level> pyramid;
};

namespace {
template <typename Tables>
void BuildPyramidImpl(const cv::Mat& depth, Tables* t) {
  using Level = typename decltype(t->pyramid)::value_type;
  const int w = t->width, h = t->height;
  t->pyramid.clear();
  if (w < 2 || h < 2) return;
  Level l0;
  l0.width = w - 1;
  l0.height = h - 1;
  const float inf = std::numeric_limits<float>::infinity();
  l0.min_depth.resize(size_t(l0.width) * l0.height);
  l0.max_depth.resize(l0.min_depth.size());
  l0.connected.resize(l0.min_depth.size());
  for (int y = 0; y + 1 < h; ++y) {
    const float* r0 = depth.ptr<float>(y);
    const float* r1 = depth.ptr<float>(y + 1);
    for (int x = 0; x + 1 < w; ++x) {
      const float d[4] = {r0[x], r0[x + 1], r1[x], r1[x + 1]};
      float lo = inf, hi = -inf;
      bool all = true;
      for (float v : d) {
        if (v > 0) {
          lo = std::min(lo, v);
          hi = std::max(hi, v);
        } else {
          all = false;
        }
      }
      const size_t idx = size_t(y) * l0.width + x;
      l0.min_depth[idx] = all ? lo : inf;
      l0.max_depth[idx] = hi;
      l0.connected[idx] = t->quad[size_t(y) * (w - 1) + x] == 3;
    }
  }
  t->pyramid.push_back(std::move(l0));
  while (t->pyramid.back().width > 1 || t->pyramid.back().height > 1) {
    const Level& a = t->pyramid.back();
    Level b;
    b.width = (a.width + 1) / 2;
    b.height = (a.height + 1) / 2;
    b.min_depth.assign(size_t(b.width) * b.height, inf);
    b.max_depth.assign(b.min_depth.size(), -inf);
    b.connected.assign(b.min_depth.size(), 1);
    for (int y = 0; y < a.height; ++y) {
      for (int x = 0; x < a.width; ++x) {
        const size_t s = size_t(y) * a.width + x, d = size_t(y / 2) * b.width + x / 2;
        b.min_depth[d] = std::min(b.min_depth[d], a.min_depth[s]);
        b.max_depth[d] = std::max(b.max_depth[d], a.max_depth[s]);
        b.connected[d] = b.connected[d] && a.connected[s];
      }
    }
    t->pyramid.push_back(std::move(b));
  }
}
}  // namespace

void BuildPyramid(const cv::Mat& depth, Integrator::CameraTables* t) { BuildPyramidImpl(depth, t); }

Integrator::Integrator(const VolumeGrid& grid, const std::vector<RangeImage>& images,
                       const FusionOptions& options)
    : grid_(grid), options_(options) {
  grid_.Check();
  options_.Check();
  cameras_.resize(images.size());
  for (size_t c = 0; c < images.size(); ++c) {
    const RangeImage& image = images[c];
    CheckRangeImage(image);
    const geometry::TsaiCamera& cam = image.camera;
    CameraTables& t = cameras_[c];
    t.rotation = cam.rotation;
    t.translation_mm = cam.translation_mm;
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
    t.lambda.resize(kLutSize);
    for (int e = 0; e < kLutSize; ++e) {
      const double rn2 = double(e) / (kLutSize - 1) * t.rn2_max;
      const double ru = cam.focal_mm * std::sqrt(rn2);
      double rd = ru;
      geometry::DistortedRadiusMm(ru, cam.kappa1_per_mm2, &rd);
      t.lambda[e] = ru > 0.0 ? static_cast<float>(rd / ru) : 1.0f;
    }
    // Inverse depths and the tessellation (seed §3: no triangle across a jump).
    t.inv_depth.resize(size_t(w) * h);
    for (int y = 0; y < h; ++y) {
      const float* row = image.depth_mm.ptr<float>(y);
      for (int x = 0; x < w; ++x)
        t.inv_depth[size_t(y) * w + x] = row[x] > 0 ? 1.0f / row[x] : 0.0f;
    }
    if (!image.weight.empty()) {
      t.weight.resize(size_t(w) * h);
      for (int y = 0; y < h; ++y) {
        const float* row = image.weight.ptr<float>(y);
        std::copy(row, row + w, t.weight.begin() + size_t(y) * w);
      }
    }
    const float ratio = static_cast<float>(options_.max_depth_jump_ratio);
    auto connected = [&](float a, float b, float c) {
      if (!(a > 0 && b > 0 && c > 0)) return false;
      const float lo = std::min(a, std::min(b, c)), hi = std::max(a, std::max(b, c));
      return hi - lo <= ratio * lo;
    };
    t.quad.assign(size_t(std::max(w - 1, 0)) * std::max(h - 1, 0), 0);
    for (int y = 0; y + 1 < h; ++y) {
      const float* r0 = image.depth_mm.ptr<float>(y);
      const float* r1 = image.depth_mm.ptr<float>(y + 1);
      for (int x = 0; x + 1 < w; ++x) {
        uint8_t q = 0;
        if (connected(r0[x], r0[x + 1], r1[x + 1])) q |= 1;  // (0,0) (1,0) (1,1)
        if (connected(r0[x], r1[x], r1[x + 1])) q |= 2;      // (0,0) (0,1) (1,1)
        t.quad[size_t(y) * (w - 1) + x] = q;
      }
    }
    BuildPyramid(image.depth_mm, &t);
  }
}

Integrator::~Integrator() = default;

// Blocks of kBlock^3 voxels aligned to the volume's absolute indices; a block's
// classification depends only on its indices, never on the slab.
constexpr int kBlock = 8;

struct Integrator::Scratch {
  std::vector<float> pu, pv, pz, ps;
  std::vector<float> sum_wd, sum_w;  // the block: kBlock^3, (k, j, i) order
  explicit Scratch(int nx)
      : pu(nx),
        pv(nx),
        pz(nx),
        ps(nx),
        sum_wd(kBlock * kBlock * kBlock),
        sum_w(kBlock * kBlock * kBlock) {}
};

// Conservative test of a whole block against one image (see FusionOptions::block_culling).
// The block is the voxels [i0, i1] x [j0, j1] x [k0, k1] (inclusive, absolute).
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
    const Eigen::Vector3d p =
        grid_.VoxelCentreMm(c & 1 ? i1 : i0, c & 2 ? j1 : j0, c & 4 ? k1 : k0);
    q[c] = t.rotation * p + t.translation_mm;
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
  double umin = 1e300, umax = -1e300, vmin = 1e300, vmax = -1e300;
  for (int c = 0; c < 8; ++c) {
    const double xn = q[c].x() / q[c].z(), yn = q[c].y() / q[c].z();
    const double rn2 = xn * xn + yn * yn;
    if (!(rn2 <= t.rn2_max)) return BlockClass::kExact;  // partly beyond the field
    const double e = rn2 * t.lut_scale;
    const int ei = std::min(static_cast<int>(e), kLutSize - 2);
    const double lambda = t.lambda[ei] + (e - ei) * (t.lambda[ei + 1] - t.lambda[ei]);
    const double u = xn * lambda * t.fx_px + t.cx_px, v = yn * lambda * t.fy_px + t.cy_px;
    umin = std::min(umin, u);
    umax = std::max(umax, u);
    vmin = std::min(vmin, v);
    vmax = std::max(vmax, v);
  }
  // The block's image lies in the corners' pixel box (it is convex and the distortion
  // bends a block edge by far less than the 2-pixel pad).
  constexpr double kPad = 2.0;
  umin -= kPad;
  vmin -= kPad;
  umax += kPad;
  vmax += kPad;
  const int w = t.width, h = t.height;
  if (umax < 0 || vmax < 0 || umin >= w - 1 || vmin >= h - 1) return BlockClass::kSkip;
  const bool inside = umin >= 0 && vmin >= 0 && umax < w - 1 && vmax < h - 1;
  const int qx0 = std::max(0, static_cast<int>(std::floor(umin)));
  const int qy0 = std::max(0, static_cast<int>(std::floor(vmin)));
  const int qx1 = std::min(w - 2, static_cast<int>(std::floor(umax)));
  const int qy1 = std::min(h - 2, static_cast<int>(std::floor(vmax)));
  // Pyramid level where the box spans at most four cells per axis.
  int level = 0;
  while (level + 1 < int(t.pyramid.size()) &&
         ((qx1 >> level) - (qx0 >> level) > 3 || (qy1 >> level) - (qy0 >> level) > 3)) {
    ++level;
  }
  const auto& L = t.pyramid[level];
  float dmin = std::numeric_limits<float>::infinity(),
        dmax = -std::numeric_limits<float>::infinity();
  bool all_connected = true;
  for (int cy = qy0 >> level; cy <= (qy1 >> level); ++cy) {
    for (int cx = qx0 >> level; cx <= (qx1 >> level); ++cx) {
      const size_t idx = size_t(cy) * L.width + cx;
      dmin = std::min(dmin, L.min_depth[idx]);
      dmax = std::max(dmax, L.max_depth[idx]);
      all_connected = all_connected && L.connected[idx];
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

// Voxels [i0, i1) of row (j, k) against one camera: a vectorizable pass that projects
// them (the camera-frame position is affine in i -- the incremental projection along
// the row, evaluated from the row's start so that it does not depend on the span),
// then a pass that samples the tessellated depth map (seed Figure 6).
void Integrator::IntegrateSpan(const CameraTables& t, int j, int k, int i0, int i1, float* sum_wd,
                               float* sum_w, Scratch* scratch) const {
  const Eigen::Vector3d c0 = t.rotation * grid_.VoxelCentreMm(0, j, k) + t.translation_mm;
  const Eigen::Vector3d s = t.rotation.col(0) * grid_.voxel_size_mm;
  float* pu = scratch->pu.data();
  float* pv = scratch->pv.data();
  float* pz = scratch->pz.data();
  float* ps = scratch->ps.data();
  const float c0x = float(c0.x()), c0y = float(c0.y()), c0z = float(c0.z());
  const float sx = float(s.x()), sy = float(s.y()), sz = float(s.z());
  const float nearf = float(options_.min_depth_mm), rn2_max = t.rn2_max, lut_scale = t.lut_scale;
  const float fx = t.fx_px, fy = t.fy_px, cx = t.cx_px, cy = t.cy_px;
  const float* lut = t.lambda.data();
  const int n = i1 - i0;
  for (int m = 0; m < n; ++m) {
    const float fi = static_cast<float>(i0 + m);
    const float x = c0x + fi * sx, y = c0y + fi * sy, z = c0z + fi * sz;
    const float inv_z = 1.0f / z;
    const float xn = x * inv_z, yn = y * inv_z;
    const float rn2 = xn * xn + yn * yn;
    const float e_raw = rn2 * lut_scale;  // NaN (z = 0) falls to the guard below
    const float e = e_raw < float(kLutSize - 1) - 0.5f ? e_raw : float(kLutSize - 1) - 0.5f;
    const int ei = static_cast<int>(e);
    const float lambda = lut[ei] + (e - float(ei)) * (lut[ei + 1] - lut[ei]);
    const bool ok = z > nearf && rn2 <= rn2_max;
    pu[m] = ok ? xn * lambda * fx + cx : -1.0f;
    pv[m] = yn * lambda * fy + cy;
    pz[m] = z;
    ps[m] = std::sqrt(1.0f + rn2);
  }
  const float truncation = static_cast<float>(options_.truncation_mm);
  const float clamp = static_cast<float>(options_.front_clamp_mm);
  const float umax = float(t.width - 1), vmax = float(t.height - 1);
  const int w = t.width;
  const float* inv_depth = t.inv_depth.data();
  const float* wmap = t.weight.empty() ? nullptr : t.weight.data();
  for (int m = 0; m < n; ++m) {
    const float u = pu[m], v = pv[m];
    if (!(u >= 0.0f && u < umax && v >= 0.0f && v < vmax)) continue;
    const int x0 = static_cast<int>(u), y0 = static_cast<int>(v);
    const float ax = u - float(x0), ay = v - float(y0);
    const uint8_t q = t.quad[size_t(y0) * (w - 1) + x0];
    if (q == 0) continue;
    const size_t p00 = size_t(y0) * w + x0;
    const size_t p10 = p00 + 1, p01 = p00 + w, p11 = p01 + 1;
    float inv, wt = 1.0f;
    if (ax >= ay) {
      if (!(q & 1)) continue;
      inv = inv_depth[p00] + ax * (inv_depth[p10] - inv_depth[p00]) +
            ay * (inv_depth[p11] - inv_depth[p10]);
      if (wmap) wt = wmap[p00] + ax * (wmap[p10] - wmap[p00]) + ay * (wmap[p11] - wmap[p10]);
    } else {
      if (!(q & 2)) continue;
      inv = inv_depth[p00] + ay * (inv_depth[p01] - inv_depth[p00]) +
            ax * (inv_depth[p11] - inv_depth[p01]);
      if (wmap) wt = wmap[p00] + ay * (wmap[p01] - wmap[p00]) + ax * (wmap[p11] - wmap[p01]);
    }
    const float d = (1.0f / inv - pz[m]) * ps[m];
    if (d < -truncation) continue;  // far behind the surface: untouched
    sum_wd[m] += wt * std::min(d, clamp);
    sum_w[m] += wt;
  }
}

// All blocks (bi, bj, bk) for bi along x, planes clipped to the slab [k0, k1). Per
// voxel the cameras are visited in their given order whatever path each takes, and the
// free-space shortcut adds exactly what the per-voxel path would (the clamp, weight 1).
void Integrator::IntegrateBlockRow(int bj, int bk, int k0, int k1, Slab* slab,
                                   Scratch* scratch) const {
  const int nx = grid_.nx, ny = grid_.ny;
  const int jb = bj * kBlock, je = std::min(ny, jb + kBlock);
  const int kb = std::max(k0, bk * kBlock), ke = std::min(k1, bk * kBlock + kBlock);
  const float clamp = static_cast<float>(options_.front_clamp_mm);
  float* sum_wd = scratch->sum_wd.data();
  float* sum_w = scratch->sum_w.data();
  for (int bi = 0; bi * kBlock < nx; ++bi) {
    const int ib = bi * kBlock, ie = std::min(nx, ib + kBlock), wi = ie - ib;
    const int voxels = (ke - kb) * (je - jb) * wi;
    std::fill(sum_wd, sum_wd + voxels, 0.0f);
    std::fill(sum_w, sum_w + voxels, 0.0f);
    // Whole block and sub-block extents are absolute (not clipped to the slab), so a
    // voxel's path never depends on the slab.
    const int bk_abs = bk * kBlock;
    const int ke_abs = std::min(grid_.nz, bk_abs + kBlock);
    for (const CameraTables& t : cameras_) {
      const BlockClass cls = ClassifyBlock(t, ib, ie - 1, jb, je - 1, bk_abs, ke_abs - 1);
      if (cls == BlockClass::kSkip) continue;
      if (cls == BlockClass::kFreeSpace) {
        for (int m = 0; m < voxels; ++m) {
          sum_wd[m] += clamp;
          sum_w[m] += 1.0f;
        }
        continue;
      }
      // Mixed: classify the eight half-size sub-blocks, sample voxel by voxel only in
      // the mixed ones (neighbouring mixed sub-blocks along a row as one span).
      constexpr int kHalf = kBlock / 2;
      BlockClass sub[2][2][2];
      for (int a = 0; a < 2; ++a) {
        const int sk = bk_abs + a * kHalf, sk_end = std::min(ke_abs, sk + kHalf);
        for (int b = 0; b < 2; ++b) {
          const int sj = jb + b * kHalf, sj_end = std::min(je, sj + kHalf);
          for (int c = 0; c < 2; ++c) {
            const int si = ib + c * kHalf, si_end = std::min(ie, si + kHalf);
            sub[a][b][c] = sk < sk_end && sj < sj_end && si < si_end && sk < ke &&
                                   sk_end > kb  // meets the slab
                               ? ClassifyBlock(t, si, si_end - 1, sj, sj_end - 1, sk, sk_end - 1)
                               : BlockClass::kSkip;
          }
        }
      }
      for (int k = kb; k < ke; ++k) {
        const int a = (k - bk_abs) / kHalf;
        for (int j = jb; j < je; ++j) {
          const int b = (j - jb) / kHalf;
          const int row = ((k - kb) * (je - jb) + (j - jb)) * wi;
          int c = 0;
          while (c < 2) {
            const int si = ib + c * kHalf;
            if (si >= ie) break;
            const BlockClass cls_c = sub[a][b][c];
            if (cls_c == BlockClass::kSkip) {
              ++c;
              continue;
            }
            if (cls_c == BlockClass::kFreeSpace) {
              const int si_end = std::min(ie, si + kHalf);
              for (int m = si - ib; m < si_end - ib; ++m) {
                sum_wd[row + m] += clamp;
                sum_w[row + m] += 1.0f;
              }
              ++c;
              continue;
            }
            int c_end = c + 1;
            while (c_end < 2 && sub[a][b][c_end] == BlockClass::kExact) ++c_end;
            const int si_end = std::min(ie, ib + c_end * kHalf);
            IntegrateSpan(t, j, k, si, si_end, sum_wd + row + (si - ib), sum_w + row + (si - ib),
                          scratch);
            c = c_end;
          }
        }
      }
    }
    for (int k = kb; k < ke; ++k) {
      for (int j = jb; j < je; ++j) {
        const int row = ((k - kb) * (je - jb) + (j - jb)) * wi;
        const size_t out = (size_t(k - k0) * ny + j) * nx + ib;
        for (int m = 0; m < wi; ++m) {
          const float w = sum_w[row + m];
          slab->weight[out + m] = w;
          slab->distance_mm[out + m] = w > 0.0f ? sum_wd[row + m] / w : 0.0f;
        }
      }
    }
  }
}

Slab Integrator::IntegrateSlab(int k0, int k1) const {
  grid_.CheckSlab(k0, k1);
  Slab slab;
  slab.k0 = k0;
  slab.k1 = k1;
  slab.nx = grid_.nx;
  slab.ny = grid_.ny;
  const size_t voxels = size_t(k1 - k0) * grid_.ny * grid_.nx;
  slab.distance_mm.resize(voxels);
  slab.weight.resize(voxels);
  // Work items: rows of blocks (bj, bk) meeting the slab, handed out dynamically (work
  // differs a lot between them); each voxel's value depends only on its indices, so the
  // schedule does not change the result.
  const int bk0 = k0 / kBlock, bk1 = (k1 - 1) / kBlock + 1;
  const int bjn = (grid_.ny + kBlock - 1) / kBlock;
  const int64_t items = int64_t(bk1 - bk0) * bjn;
  const int threads = static_cast<int>(std::max<int64_t>(
      1, std::min<int64_t>(
             options_.num_threads > 0 ? options_.num_threads : core::HardwareThreads(), items)));
  std::atomic<int64_t> next{0};
  core::ParallelFor(0, threads, threads, [&](int64_t, int64_t) {
    Scratch scratch(grid_.nx);
    for (int64_t item; (item = next.fetch_add(1)) < items;) {
      const int bk = bk0 + static_cast<int>(item / bjn), bj = static_cast<int>(item % bjn);
      IntegrateBlockRow(bj, bk, k0, k1, &slab, &scratch);
    }
  });
  return slab;
}

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
