#include "stereo/cost_kernel.h"

#include <immintrin.h>

#include <algorithm>
#include <atomic>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "core/error.h"
#include "core/parallel_for.h"
#include "stereo/window_sum.h"

namespace dome::stereo {

// c[x] = sum of v[x..x+2h], x in [0, n). Narrow windows: sixteen sums at a time kept in
// registers (one store each), the tail one by one. Windows of 9 or more: the sums of 2,
// 4, 8, ... consecutive values, each from two of the one before, and the window tiled
// by those of its binary digits, added in one pass: log2(taps) + 1 passes over the row
// instead of taps loads per value (at 17 px, 5 passes; it was a quarter of a Robovision
// stereo job). The order of the additions depends only on the window, whatever the CPU.
__attribute__((noinline)) void WindowSum(const float* __restrict v, int n, int h,
                                         float* __restrict c) {
  const int taps = 2 * h + 1;
  if (taps >= 9) {
    const int total = n + taps - 1;  // values of v read
    // pow[k]: the sums of 2^k consecutive values (pow[0] is v itself).
    thread_local std::vector<std::vector<float>> pow;
    const float* level[8] = {v};
    int k = 0;
    for (int len = 1; 2 * len <= taps; len *= 2, ++k) {
      if (int(pow.size()) <= k) pow.resize(k + 1);
      pow[k].resize(size_t(total));
      const float* __restrict a = level[k];
      float* __restrict out = pow[k].data();
      const int m = total - 2 * len + 1;
      for (int x = 0; x < m; ++x) out[x] = a[x] + a[x + len];
      level[k + 1] = out;
    }
    // The window's pieces, largest first from its start: e.g. 17 = 16 + 1.
    const float* piece[8];
    int pieces = 0, offset = 0;
    for (int b = k; b >= 0; --b) {
      if (taps & (1 << b)) {
        piece[pieces++] = level[b] + offset;
        offset += 1 << b;
      }
    }
    if (pieces == 1) {
      std::memcpy(c, piece[0], sizeof(float) * size_t(n));
    } else {
      const float* __restrict p0 = piece[0];
      const float* __restrict p1 = piece[1];
      for (int x = 0; x < n; ++x) c[x] = p0[x] + p1[x];
    }
    for (int p = 2; p < pieces; ++p) {
      const float* __restrict add = piece[p];
      for (int x = 0; x < n; ++x) c[x] += add[x];
    }
    return;
  }
  // A generic vector type of the target's widest register: 16 floats with AVX-512, 8
  // otherwise (a 16-float type on an AVX2 target went through the stack, and this loop
  // was a quarter of an AVX2 build's stereo time). Each sum's order is the same.
#if defined(__AVX512F__)
  typedef float FV __attribute__((vector_size(64)));
#else
  typedef float FV __attribute__((vector_size(32)));
#endif
  constexpr int kLanes = int(sizeof(FV) / sizeof(float));
  int x = 0;
  for (; x + kLanes <= n; x += kLanes) {
    FV acc, t;
    std::memcpy(&acc, v + x, sizeof(acc));
    for (int d = 1; d < taps; ++d) {
      std::memcpy(&t, v + x + d, sizeof(t));
      acc += t;
    }
    std::memcpy(c + x, &acc, sizeof(acc));
  }
  for (; x < n; ++x) {
    float acc = v[x];
    for (int d = 1; d < taps; ++d) acc += v[x + d];
    c[x] = acc;
  }
}

namespace {

constexpr int kBandRows = kKernelTilePx;  // a band is one row of tiles
constexpr int kLevelGroup = 4;  // levels per pass of the minimum update (UpdateRowN)
constexpr float kInf = std::numeric_limits<float>::infinity();

// Packed taps (SIMD path): grey g is stored as the 8-bit code round(g) clamped to
// 0..254 (normalized contrast can leave 0..255 at the 1% tails); 255 marks a pixel
// without data. Word (x, y) = code(x, y) | code(x + 1, y) << 8 | code(x, y + 1) << 16 |
// code(x + 1, y + 1) << 24: one 32-bit gather gives a pixel's four bilinear taps, and
// any byte 255 says the quad has no data. (Gathers are much of the warp's cost: this
// needs one per pixel instead of four.)
constexpr uint32_t kNoData = 255;

std::vector<uint32_t> PackTaps(const KernelNeighbour& nb) {
  const int w = nb.width, h = nb.height;
  // 32 words of padding for the contiguous loads of AccumulateRowAvx512.
  std::vector<uint32_t> taps(size_t(w) * h + 32, 0xffffffffu);
  auto code = [&](int x, int y) -> uint32_t {
    if (x >= w || y >= h) return kNoData;
    const float g = nb.image[size_t(y) * w + x];
    if (!(g == g)) return kNoData;
    return uint32_t(std::clamp(std::round(g), 0.0f, float(kNoData - 1)));
  };
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      taps[size_t(y) * w + x] =
          code(x, y) | code(x + 1, y) << 8 | code(x, y + 1) << 16 | code(x + 1, y + 1) << 24;
    }
  }
  return taps;
}

// Adds, for x in [0, n), the squared differences of reference row y against neighbour
// `nb` warped by the homography of inverse depth w (scalar path; float image, NaN =
// no data). The four bilinear taps are gathers with one 32-bit index.
void AccumulateRowScalar(const KernelNeighbour& nb, float w, int y, int n,
                         const float* __restrict ref, float outside_cost, float* __restrict ssd) {
  // q(x) = a (x, y, 1) + w b = q0 + x * dq
  const float q0x = float(nb.a[0][1] * y + nb.a[0][2] + w * nb.b[0]);
  const float q0y = float(nb.a[1][1] * y + nb.a[1][2] + w * nb.b[1]);
  const float q0z = float(nb.a[2][1] * y + nb.a[2][2] + w * nb.b[2]);
  const float dqx = float(nb.a[0][0]), dqy = float(nb.a[1][0]), dqz = float(nb.a[2][0]);
  const float umax = float(nb.width - 1), vmax = float(nb.height - 1);
  const int stride = nb.width;
  const float* __restrict i00 = nb.image;
  const float* __restrict i01 = nb.image + 1;
  const float* __restrict i10 = nb.image + stride;
  const float* __restrict i11 = nb.image + stride + 1;
  for (int x = 0; x < n; ++x) {
    const float fx = float(x);
    const float qz = q0z + fx * dqz;
    const float iz = 1.0f / qz;
    float u = (q0x + fx * dqx) * iz;
    float v = (q0y + fx * dqy) * iz;
    const bool in = (qz > 0.0f) & (u >= 0.0f) & (v >= 0.0f) & (u < umax) & (v < vmax);
    u = in ? u : 0.0f;
    v = in ? v : 0.0f;
    const int xi = int(u), yi = int(v);
    const float ax = u - float(xi), ay = v - float(yi);
    const int i = yi * stride + xi;
    const float p00 = i00[i], p01 = i01[i], p10 = i10[i], p11 = i11[i];
    const float top = p00 + ax * (p01 - p00);
    const float bot = p10 + ax * (p11 - p10);
    const float val = top + ay * (bot - top);
    const float d = ref[x] - val;
    const float c = d * d;
    ssd[x] += (in & (c == c)) ? c : outside_cost;
  }
}

// The same for x in [0, n8), n8 a multiple of 8, eight pixels at a time with AVX2/FMA
// on the packed taps. `ref_neg` is minus the reference grey. The reciprocal of the homogeneous
// coordinate is a division, rounded as IEEE requires on every CPU: rcp's approximation
// differs between instruction sets (12 bits here, 14 with AVX-512) and between CPU
// makers, and after a Newton step the last bit of u and v did too, so the AVX2 and
// AVX-512 paths, and two AVX2 CPUs, gave different costs and depths (2,383 of a small
// synthetic take's 19,200 depths, by up to 0.007 mm).
__attribute__((target("avx2,fma"))) void AccumulateRowAvx2(
    const KernelNeighbour& nb, const uint32_t* __restrict taps, float w, int y, int n8,
    const float* __restrict ref_neg, float outside_cost, float* __restrict ssd) {
  const float q0x = float(nb.a[0][1] * y + nb.a[0][2] + w * nb.b[0]);
  const float q0y = float(nb.a[1][1] * y + nb.a[1][2] + w * nb.b[1]);
  const float q0z = float(nb.a[2][1] * y + nb.a[2][2] + w * nb.b[2]);
  const __m256 dqx = _mm256_set1_ps(float(nb.a[0][0]));
  const __m256 dqy = _mm256_set1_ps(float(nb.a[1][0]));
  const __m256 dqz = _mm256_set1_ps(float(nb.a[2][0]));
  const __m256 vq0x = _mm256_set1_ps(q0x), vq0y = _mm256_set1_ps(q0y);
  const __m256 vq0z = _mm256_set1_ps(q0z);
  const __m256 umax = _mm256_set1_ps(float(nb.width - 1));
  const __m256 vmax = _mm256_set1_ps(float(nb.height - 1));
  const __m256 stride = _mm256_set1_ps(float(nb.width));
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  const __m256 eight = _mm256_set1_ps(8.0f);
  const __m256 outside = _mm256_set1_ps(outside_cost);
  const __m256i byte = _mm256_set1_epi32(0xff), no_data = _mm256_set1_epi8(char(kNoData));
  const int* base = reinterpret_cast<const int*>(taps);
  __m256 fx = _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7);
  for (int x = 0; x < n8; x += 8, fx = _mm256_add_ps(fx, eight)) {
    const __m256 qz = _mm256_fmadd_ps(fx, dqz, vq0z);
    const __m256 qx = _mm256_fmadd_ps(fx, dqx, vq0x);
    const __m256 qy = _mm256_fmadd_ps(fx, dqy, vq0y);
    const __m256 r = _mm256_div_ps(one, qz);
    __m256 u = _mm256_mul_ps(qx, r), v = _mm256_mul_ps(qy, r);
    __m256 in = _mm256_cmp_ps(qz, zero, _CMP_GT_OQ);
    in = _mm256_and_ps(in, _mm256_cmp_ps(u, zero, _CMP_GE_OQ));
    in = _mm256_and_ps(in, _mm256_cmp_ps(v, zero, _CMP_GE_OQ));
    in = _mm256_and_ps(in, _mm256_cmp_ps(u, umax, _CMP_LT_OQ));
    in = _mm256_and_ps(in, _mm256_cmp_ps(v, vmax, _CMP_LT_OQ));
    u = _mm256_and_ps(u, in);
    v = _mm256_and_ps(v, in);
    // u, v >= 0 here, so truncation is the floor.
    const __m256 fu = _mm256_cvtepi32_ps(_mm256_cvttps_epi32(u));
    const __m256 fv = _mm256_cvtepi32_ps(_mm256_cvttps_epi32(v));
    const __m256 ax = _mm256_sub_ps(u, fu), ay = _mm256_sub_ps(v, fv);
    // Exact in float below 2^24 pixels (checked by the caller).
    const __m256i idx = _mm256_cvttps_epi32(_mm256_fmadd_ps(fv, stride, fu));
    const __m256i g = _mm256_i32gather_epi32(base, idx, 4);
    const __m256 p00 = _mm256_cvtepi32_ps(_mm256_and_si256(g, byte));
    const __m256 p01 = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(g, 8), byte));
    const __m256 p10 = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(g, 16), byte));
    const __m256 p11 = _mm256_cvtepi32_ps(_mm256_srli_epi32(g, 24));
    const __m256 top = _mm256_fmadd_ps(ax, _mm256_sub_ps(p01, p00), p00);
    const __m256 bot = _mm256_fmadd_ps(ax, _mm256_sub_ps(p11, p10), p10);
    const __m256 val = _mm256_add_ps(_mm256_fmadd_ps(ay, _mm256_sub_ps(bot, top), top),
                                     _mm256_loadu_ps(ref_neg + x));
    const __m256 d = val;
    // A lane is good when none of its bytes is kNoData.
    const __m256i bad_bytes = _mm256_cmpeq_epi8(g, no_data);
    const __m256 good = _mm256_castsi256_ps(_mm256_cmpeq_epi32(bad_bytes, _mm256_setzero_si256()));
    const __m256 ok = _mm256_and_ps(good, in);
    const __m256 c = _mm256_blendv_ps(outside, _mm256_mul_ps(d, d), ok);
    _mm256_storeu_ps(ssd + x, _mm256_add_ps(_mm256_loadu_ps(ssd + x), c));
  }
}

// The same with AVX-512 (F, BW), sixteen pixels at a time, n16 a multiple of 16: masked
// gathers and compares into mask registers take the place of the AVX2 blends.
//
// kFirst: store the cost instead of adding it (the first neighbour of a level).
// kHoles: the neighbour has pixels without data (otherwise only lanes outside it do).
template <bool kFirst, bool kHoles>
__attribute__((target("avx512f,avx512bw,fma"))) void AccumulateRowAvx512(
    const KernelNeighbour& nb, const uint32_t* __restrict taps, float w, int y, int n16,
    const float* __restrict ref_neg, float outside_cost, float* __restrict ssd) {
  const float q0x = float(nb.a[0][1] * y + nb.a[0][2] + w * nb.b[0]);
  const float q0y = float(nb.a[1][1] * y + nb.a[1][2] + w * nb.b[1]);
  const float q0z = float(nb.a[2][1] * y + nb.a[2][2] + w * nb.b[2]);
  const __m512 dqx = _mm512_set1_ps(float(nb.a[0][0]));
  const __m512 dqy = _mm512_set1_ps(float(nb.a[1][0]));
  const __m512 dqz = _mm512_set1_ps(float(nb.a[2][0]));
  const __m512 vq0x = _mm512_set1_ps(q0x), vq0y = _mm512_set1_ps(q0y);
  const __m512 vq0z = _mm512_set1_ps(q0z);
  const __m512i xlimit = _mm512_set1_epi32(nb.width - 1);
  const __m512i ylimit = _mm512_set1_epi32(nb.height - 1);
  const __m512 stride = _mm512_set1_ps(float(nb.width));
  const __m512 zero = _mm512_setzero_ps(), one = _mm512_set1_ps(1.0f);
  const __m512 sixteen = _mm512_set1_ps(16.0f);
  const __m512 outside = _mm512_set1_ps(outside_cost);
  const __m512i byte = _mm512_set1_epi32(0xff), no_data = _mm512_set1_epi8(char(kNoData));
  const __m512i all_no_data = _mm512_set1_epi32(-1);
  __m512 fx = _mm512_setr_ps(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  for (int x = 0; x < n16; x += 16, fx = _mm512_add_ps(fx, sixteen)) {
    const __m512 qz = _mm512_fmadd_ps(fx, dqz, vq0z);
    const __m512 qx = _mm512_fmadd_ps(fx, dqx, vq0x);
    const __m512 qy = _mm512_fmadd_ps(fx, dqy, vq0y);
    const __m512 r = _mm512_div_ps(one, qz);  // as AccumulateRowAvx2's
    const __m512 u = _mm512_mul_ps(qx, r), v = _mm512_mul_ps(qy, r);
    const __m512 fu = _mm512_roundscale_ps(u, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
    const __m512 fv = _mm512_roundscale_ps(v, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
    const __m512 ax = _mm512_sub_ps(u, fu), ay = _mm512_sub_ps(v, fv);
    // 0 <= u < width-1 and 0 <= v < height-1 as unsigned compares of the floors (NaN and
    // out-of-range values convert to 0x80000000, which fails them).
    const __m512i xi = _mm512_cvttps_epi32(fu), yi = _mm512_cvttps_epi32(fv);
    const __mmask16 in = _mm512_cmp_ps_mask(qz, zero, _CMP_GT_OQ) &
                         _mm512_cmplt_epu32_mask(xi, xlimit) & _mm512_cmplt_epu32_mask(yi, ylimit);
    // Along a reference row the warped points mostly stay on one or two neighbour rows
    // and within 32 pixels of each other: then contiguous loads and permutes stand in
    // for the gather, which costs about as much as the rest of the loop.
    __m512i g = all_no_data;  // lanes outside look like "no data"
    if (in != 0) {
      int x_base, y_base;
      if (in == 0xffff) {
        // u and v are monotone along the row (qz > 0): the ends hold the least.
        x_base = std::min(_mm_cvtsi128_si32(_mm512_castsi512_si128(xi)),
                          _mm_extract_epi32(_mm512_extracti32x4_epi32(xi, 3), 3));
        y_base = std::min(_mm_cvtsi128_si32(_mm512_castsi512_si128(yi)),
                          _mm_extract_epi32(_mm512_extracti32x4_epi32(yi, 3), 3));
      } else {
        x_base = _mm512_mask_reduce_min_epi32(in, xi);
        y_base = _mm512_mask_reduce_min_epi32(in, yi);
      }
      const __m512i rel = _mm512_sub_epi32(xi, _mm512_set1_epi32(x_base));
      const __m512i dy = _mm512_sub_epi32(yi, _mm512_set1_epi32(y_base));
      const __mmask16 row0 = in & _mm512_cmpeq_epi32_mask(dy, _mm512_setzero_si512());
      const __mmask16 row1 = in & _mm512_cmpeq_epi32_mask(dy, _mm512_set1_epi32(1));
      const __mmask16 near = _mm512_cmplt_epu32_mask(rel, _mm512_set1_epi32(32)) & (row0 | row1);
      if (near == in) {
        // taps is padded by 32 words, so the loads stay inside it.
        const uint32_t* p = taps + size_t(y_base) * nb.width + x_base;
        g = _mm512_mask_mov_epi32(
            g, row0,
            _mm512_permutex2var_epi32(_mm512_loadu_si512(p), rel, _mm512_loadu_si512(p + 16)));
        if (row1) {
          p += nb.width;
          g = _mm512_mask_mov_epi32(
              g, row1,
              _mm512_permutex2var_epi32(_mm512_loadu_si512(p), rel, _mm512_loadu_si512(p + 16)));
        }
      } else {
        // Exact in float below 2^24 pixels (checked by the caller).
        const __m512i idx = _mm512_cvttps_epi32(_mm512_fmadd_ps(fv, stride, fu));
        g = _mm512_mask_i32gather_epi32(all_no_data, in, idx, taps, 4);
      }
    }
    const __m512 p00 = _mm512_cvtepi32_ps(_mm512_and_si512(g, byte));
    const __m512 p01 = _mm512_cvtepi32_ps(_mm512_and_si512(_mm512_srli_epi32(g, 8), byte));
    const __m512 p10 = _mm512_cvtepi32_ps(_mm512_and_si512(_mm512_srli_epi32(g, 16), byte));
    const __m512 p11 = _mm512_cvtepi32_ps(_mm512_srli_epi32(g, 24));
    const __m512 top = _mm512_fmadd_ps(ax, _mm512_sub_ps(p01, p00), p00);
    const __m512 bot = _mm512_fmadd_ps(ax, _mm512_sub_ps(p11, p10), p10);
    const __m512 d = _mm512_add_ps(_mm512_fmadd_ps(ay, _mm512_sub_ps(bot, top), top),
                                   _mm512_loadu_ps(ref_neg + x));
    __mmask16 ok = in;
    if constexpr (kHoles) {
      // Good lanes: no byte is kNoData.
      const __m512i bad_bytes = _mm512_movm_epi8(_mm512_cmpeq_epi8_mask(g, no_data));
      ok = _mm512_testn_epi32_mask(bad_bytes, bad_bytes);
    }
    const __m512 c = _mm512_mask_mul_ps(outside, ok, d, d);
    if constexpr (kFirst) {
      _mm512_storeu_ps(ssd + x, c);
    } else {
      _mm512_storeu_ps(ssd + x, _mm512_add_ps(_mm512_loadu_ps(ssd + x), c));
    }
  }
}

// Kernel buffers are taken from and given back to a process-wide pool: fresh pages
// cost a page fault each on first touch, megabytes per call otherwise.
template <class T>
class Pool {
 public:
  // A vector of n elements, contents unspecified.
  static std::vector<T> Take(size_t n) {
    std::vector<T> v;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      auto& free = Free();
      size_t pick = free.size();
      for (size_t i = 0; i < free.size(); ++i) {
        const size_t cap = free[i].capacity();
        if (cap >= n && (pick == free.size() || cap < free[pick].capacity())) pick = i;
      }
      if (pick < free.size()) {
        v = std::move(free[pick]);
        free.erase(free.begin() + pick);
      }
    }
    v.resize(n);
    return v;
  }
  static void Give(std::vector<T>* v) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto& free = Free();
    if (free.size() < kMaxBuffers) free.push_back(std::move(*v));
  }

 private:
  static constexpr size_t kMaxBuffers = 256;
  static std::vector<std::vector<T>>& Free() {
    static std::vector<std::vector<T>> free;
    return free;
  }
  static inline std::mutex mutex_;
};
using FloatPool = Pool<float>;

// A pooled buffer for the scope.
struct Scratch {
  std::vector<float> v;
  explicit Scratch(size_t n = 0) : v(FloatPool::Take(n)) {}
  ~Scratch() { FloatPool::Give(&v); }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;
  float* data() { return v.data(); }
  const float* data() const { return v.data(); }
  float& operator[](size_t i) { return v[i]; }
  float operator[](size_t i) const { return v[i]; }
};

struct BandState {
  // Per pixel of the band (rows x stride), one set per window size.
  Scratch best, level, cm, cp, before, after, run, run_prev, prev;
  void Reset(size_t n) {
    best.v.assign(n, kInf);
    level.v.assign(n, -1.0f);
    cm.v.assign(n, kInf);
    cp.v.assign(n, kInf);
    before.v.assign(n, kInf);
    after.v.assign(n, kInf);
    run.v.assign(n, kInf);
    run_prev.v.assign(n, kInf);
    prev.v.assign(n, kInf);
  }
};

// Streaming minimum over levels, exact:
//   best/level: least cost and its level (the first on ties);
//   cm: cost at level-1 (kept from `prev` when the minimum moves here);
//   cp: cost at level+1 (taken at the next level);
//   before: least cost over levels <= level-2 (`run_prev`, the prefix minimum two
//           levels back, when the minimum moves here);
//   after: least cost over levels >= level+2.
// second = min(before, after).
// The update for K consecutive levels (lvl + k with costs c[k]) in one pass over the
// state, 1/K of the state traffic (the state of a band lives in L2, and loading and
// storing it is most of the update's time). Plain selects on floats only, so that GCC
// vectorizes it.
template <int K>
__attribute__((noinline)) void UpdateRowN(const float* const* c, int n, float lvl,
                                          float* __restrict best, float* __restrict level,
                                          float* __restrict cm, float* __restrict cp,
                                          float* __restrict before, float* __restrict after,
                                          float* __restrict run, float* __restrict run_prev,
                                          float* __restrict prev) {
  const float* __restrict ck[K];
  for (int k = 0; k < K; ++k) ck[k] = c[k];
  for (int x = 0; x < n; ++x) {
    float b = best[x], lv = level[x], rn = run[x], rp = run_prev[x], pv = prev[x];
    float bf = before[x], cmv = cm[x], cpv = cp[x], af = after[x];
    for (int k = 0; k < K; ++k) {
      const float cv = ck[k][x];
      const float l = lvl + float(k);
      const bool nb = cv < b;
      const bool adj = l == lv + 1.0f;
      const float af_min = cv < af ? cv : af;
      bf = nb ? rp : bf;
      cmv = nb ? pv : cmv;
      cpv = nb ? kInf : (adj ? cv : cpv);
      af = nb ? kInf : (adj ? af : af_min);
      b = nb ? cv : b;
      lv = nb ? l : lv;
      rp = rn;
      rn = cv < rn ? cv : rn;
      pv = cv;
    }
    best[x] = b, level[x] = lv, run[x] = rn, run_prev[x] = rp, prev[x] = pv;
    before[x] = bf, cm[x] = cmv, cp[x] = cpv, after[x] = af;
  }
}

// UpdateRowN<g + 1> for a group of g + 1 levels.
using UpdateRowFn = void (*)(const float* const*, int, float, float*, float*, float*, float*,
                             float*, float*, float*, float*, float*);
template <size_t... K>
constexpr std::array<UpdateRowFn, sizeof...(K)> UpdateRowTable(std::index_sequence<K...>) {
  return {UpdateRowN<int(K) + 1>...};
}
constexpr auto kUpdateRow = UpdateRowTable(std::make_index_sequence<kLevelGroup>());

// Pre-warped neighbours (KernelInput::prewarp). With c = A^-1 b, x_n ~ A (p + w c): in
// the neighbour resampled once by A onto the reference's pixel grid ("J", bicubic),
// hypothesis w takes reference pixel p to m = (p + w c_xy) s with s = 1 / (1 + w c_z),
// a scaling. So per level and neighbour a reference row reads one fixed J row pair
// and J columns that are affine in x with the same pattern (column, fraction) for
// every row: no per-pixel division and no per-pixel address logic. Each J row a level
// needs is resampled along x once and serves the two reference rows that fall next to
// it; the vertical interpolation, difference and square follow per reference row
// (VerticalSsdQ*). Where a J row has no holes (the usual case: data ends only at the
// neighbour's image border) the pixels whose samples have data are one run, found from
// the pattern (PixelRun), and blocks outside it are neither resampled nor interpolated.
//
// All of it is integer arithmetic in 16-bit fixed point (greys x kQ) up to one float
// conversion and one fused multiply-add per pixel, so the AVX-512 path (32 pixels per
// instruction, two permutes of a contiguous pair of loads per 32 pixels), the AVX2 path
// (16 pixels, byte shuffles of short loads: its gathers are slower than scalar loads)
// and the scalar path give the same bits, and a cluster of mixed CPUs the same depths.
// The pattern itself is computed once, outside the SIMD instances, with explicit fused
// multiply-adds, so that no compiler contraction can tell the paths apart.
struct Prewarped {
  int cols = 0, rows = 0;
  double ox = 0.0, oy = 0.0;  // m of J pixel (0, 0), in reference pixels
  double c[3] = {0.0, 0.0, 0.0};
  std::vector<uint8_t> has_data;  // per row: any J pixel with data
  // J in fixed point (kQ): grey x 32 clamped to 0..255 grey (0 where no data), and
  // pair_ok[c] = -1 where J(c) and J(c + 1) both have data, else 0; rows x qstride.
  // Per row, pair_ok is -1 on all of [ok_lo, ok_hi] when ok_run.
  int qstride = 0;
  std::vector<int16_t> q, pair_ok;
  std::vector<int32_t> ok_lo, ok_hi;
  std::vector<uint8_t> ok_run;
};

// The column pattern of the fixed point paths, in blocks of 32 pixels stored in the
// order that 16-bit unpacks of two neighbours' rows put back in pixel order
// (StoredPixel): position 8 L + j of a block holds pixel 4 L + j, position 8 L + 4 + j
// pixel 16 + 4 L + j (L = 0..3, j = 0..3). Positions 4 G..4 G + 3 (group G) hold
// consecutive pixels; a 256-bit register holds positions 0..15 or 16..31, groups
// 2 L (positions 8 L..8 L + 3) and 2 L + 1 in its 128-bit lanes.
struct LevelPattern16 {
  double s = 1.0, my0 = 0.0;  // J row coordinate of reference row y: s y + my0
  double mx0 = 0.0;           // J column coordinate of pixel x: s x + mx0
  std::vector<int32_t> base;  // per block: J column of its first pixel
  std::vector<int16_t> rel;   // per position: J column - block base
  std::vector<int16_t> frac;  // per position: fraction of the J column, Q15
  // Per block: too far for the SIMD path's loads, resampled one position at a time
  // (AVX-512: rel + 1 passes 63; AVX2: a group's taps span more than 8 columns).
  std::vector<uint8_t> scalar;
  // AVX2: per position, the bytes of its left tap in the 8 columns loaded from its
  // group's first column (2 r, 2 r + 1 for column offset r), as _mm256_shuffle_epi8
  // takes them; 2 x 32 bytes per block.
  std::vector<uint8_t> shuffle;
};

// Fixed point greys: grey x kQ in 16 bits. Squared differences of two neighbours sum in
// 32 bits (2 x (255 kQ)^2 < 2^27), so up to kMaxQNeighbours neighbours fit.
constexpr int kQ = 32;
constexpr int kMaxQNeighbours = 32;

constexpr int StoredPixel(int p) {
  return (p & 4) ? 16 + 4 * (p >> 3) + (p & 3) : 4 * (p >> 3) + (p & 3);
}

constexpr double kMaxPrewarpScale = 4.0;  // s beyond this: neighbour near the plane's horizon
constexpr double kMaxPrewarpArea = 16.0;  // J larger than this many reference images: no
// NaN J pixels around the reach of every hypothesis: clamped reads outside J land there.
constexpr int kPrewarpMargin = 2;

bool Invert3(const double a[3][3], double inv[3][3]) {
  const double c00 = a[1][1] * a[2][2] - a[1][2] * a[2][1];
  const double c01 = a[1][2] * a[2][0] - a[1][0] * a[2][2];
  const double c02 = a[1][0] * a[2][1] - a[1][1] * a[2][0];
  const double det = a[0][0] * c00 + a[0][1] * c01 + a[0][2] * c02;
  if (!(std::abs(det) > 1e-300)) return false;
  inv[0][0] = c00 / det;
  inv[0][1] = (a[0][2] * a[2][1] - a[0][1] * a[2][2]) / det;
  inv[0][2] = (a[0][1] * a[1][2] - a[0][2] * a[1][1]) / det;
  inv[1][0] = c01 / det;
  inv[1][1] = (a[0][0] * a[2][2] - a[0][2] * a[2][0]) / det;
  inv[1][2] = (a[0][2] * a[1][0] - a[0][0] * a[1][2]) / det;
  inv[2][0] = c02 / det;
  inv[2][1] = (a[0][1] * a[2][0] - a[0][0] * a[2][1]) / det;
  inv[2][2] = (a[0][0] * a[1][1] - a[0][1] * a[1][0]) / det;
  return true;
}

// Reference pixels [x0, x1] x [y0, y1] searched over inverse depths [w0, w1].
struct Reach {
  double x0, y0, x1, y1, w0, w1;
};

// Sets up J's extent for the reaches (m is affine in the pixel and monotone in w, so
// the corners and the ends of each reach bound it); false when the scaling leaves the
// usable range (then the exact per-pixel warp runs).
bool PlanPrewarp(const KernelNeighbour& nb, int width, int height,
                 const std::vector<Reach>& reaches, Prewarped* pw) {
  double inv[3][3];
  if (!Invert3(nb.a, inv)) return false;
  for (int i = 0; i < 3; ++i) {
    pw->c[i] = inv[i][0] * nb.b[0] + inv[i][1] * nb.b[1] + inv[i][2] * nb.b[2];
  }
  double xmin = kInf, xmax = -kInf, ymin = kInf, ymax = -kInf;
  for (const Reach& r : reaches) {
    for (double w : {r.w0, r.w1}) {
      const double d = 1.0 + w * pw->c[2];
      if (!(d > 1.0 / kMaxPrewarpScale)) return false;
      for (double x : {r.x0, r.x1}) {
        for (double y : {r.y0, r.y1}) {
          const double mx = (x + w * pw->c[0]) / d, my = (y + w * pw->c[1]) / d;
          xmin = std::min(xmin, mx), xmax = std::max(xmax, mx);
          ymin = std::min(ymin, my), ymax = std::max(ymax, my);
        }
      }
    }
  }
  // Where J has data at all: the neighbour's image mapped back by A^-1, when all of it
  // lies in front of the reference (else the reach above bounds J alone). Outside J,
  // clamped reads land on its NaN margin.
  double fxmin = kInf, fxmax = -kInf, fymin = kInf, fymax = -kInf;
  bool bounded = true;
  for (double u : {0.0, double(nb.width - 1)}) {
    for (double v : {0.0, double(nb.height - 1)}) {
      const double mz = inv[2][0] * u + inv[2][1] * v + inv[2][2];
      if (!(mz > 0.0)) bounded = false;
      const double mx = (inv[0][0] * u + inv[0][1] * v + inv[0][2]) / mz;
      const double my = (inv[1][0] * u + inv[1][1] * v + inv[1][2]) / mz;
      fxmin = std::min(fxmin, mx), fxmax = std::max(fxmax, mx);
      fymin = std::min(fymin, my), fymax = std::max(fymax, my);
    }
  }
  if (bounded) {
    xmin = std::max(xmin, fxmin), xmax = std::min(xmax, fxmax);
    ymin = std::max(ymin, fymin), ymax = std::min(ymax, fymax);
    if (!(xmin <= xmax && ymin <= ymax)) xmin = xmax = ymin = ymax = 0.0;  // never seen
  }
  pw->ox = std::floor(xmin) - kPrewarpMargin;
  pw->oy = std::floor(ymin) - kPrewarpMargin;
  const double cols = std::ceil(xmax) - pw->ox + kPrewarpMargin + 1;
  const double rows = std::ceil(ymax) - pw->oy + kPrewarpMargin + 1;
  if (!(cols * rows <= kMaxPrewarpArea * width * height)) return false;
  pw->cols = int(cols);
  pw->rows = int(rows);
  pw->qstride = pw->cols + 80;  // the AVX-512 permutes load 64 columns from a block's base
  return true;
}

// Catmull-Rom (Keys, a = -1/2) weights of the taps at -1, 0, 1, 2 for fraction t.
// Weights of the taps at -1, 0, 1, 2 for fraction t: Keys' cubic convolution with
// a = -1.25 rather than the usual -0.5 (Catmull-Rom). The sharper kernel makes up for
// the blur of the bilinear resampling of J at each level. On the synthetic dome's paper
// take (median error, within 1%) windows 5 / 9 / 13 gave 12.89 mm, 0.709 / 14.16,
// 0.734 / 18.35, 0.612 at -0.5, 12.59, 0.722 / 14.18, 0.733 / 18.71, 0.605 at -1.25
// and 12.54, 0.724 / 14.18, 0.732 / 18.88, 0.601 at -1.5; the exact warp 12.55, 0.718 /
// 14.27, 0.731 / 18.74, 0.603.
// T is float or a vector of floats (the same expressions per lane).
template <class T>
inline __attribute__((always_inline)) void CubicWeights(T t, T w[4]) {
  // Keys' kernel: (a + 2)|x|^3 - (a + 3)|x|^2 + 1 for |x| <= 1, a (|x| - 1)(|x| - 2)^2
  // for 1 < |x| < 2.
  constexpr float kA = -1.25f;
  const T u = 1.0f - t;
  w[0] = kA * t * u * u;
  w[1] = ((kA + 2.0f) * t - (kA + 3.0f)) * t * t + 1.0f;
  w[2] = ((kA + 2.0f) * u - (kA + 3.0f)) * u * u + 1.0f;
  w[3] = kA * t * t * u;
}

// The bicubic taps of FillPrewarp, kPrewarpLanes J pixels per block: lane l of block b
// reads the 4x4 floats around image[corner[l]] (rows -1..2, columns -1..2; the image
// is `stride` floats wide) when bicubic[l], else zeros (four rows, `stride` apart),
// into out[((b 16) + 4 k + c) kPrewarpLanes + l] (row k, column c). Data movement only,
// so the paths give the same J.
constexpr int kPrewarpLanes = 16;

inline const float* FirstTap(const float* image, const int64_t* corner, const int32_t* bicubic,
                             const float* zeros, int stride, int l) {
  return bicubic[l] ? image + corner[l] - stride - 1 : zeros;
}

void GatherTapsScalar(const float* image, const int64_t* corner, const int32_t* bicubic,
                      const float* zeros, int stride, int blocks, float* __restrict out) {
  for (int l = 0; l < blocks * kPrewarpLanes; ++l) {
    const float* first = FirstTap(image, corner, bicubic, zeros, stride, l);
    float* t = out + size_t(l / kPrewarpLanes) * 16 * kPrewarpLanes + l % kPrewarpLanes;
    for (int k = 0; k < 4; ++k) {
      for (int c = 0; c < 4; ++c) t[(4 * k + c) * kPrewarpLanes] = first[size_t(k) * stride + c];
    }
  }
}

// With AVX-512: per tap row, each lane's four taps are one 128-bit load; four lanes
// fill a register, and two-source permutes and a blend turn the four registers
// (lanes x columns) into one per column (columns x lanes).
__attribute__((target("avx512f,avx512bw,fma"))) void GatherTapsAvx512(
    const float* image, const int64_t* corner, const int32_t* bicubic, const float* zeros,
    int stride, int blocks, float* __restrict out) {
  static_assert(kPrewarpLanes == 16);
  // Register g holds lanes 4 g..4 g + 3, four columns each; column c of lane 4 g + j
  // sits at 4 j + c. Lanes 0..7 come from registers 0 and 1, lanes 8..15 from 2 and 3,
  // by the same index (the lane within its pair of registers).
  __m512i index[4];
  for (int c = 0; c < 4; ++c) {
    alignas(64) int32_t lanes[16];
    for (int lane = 0; lane < 16; ++lane) {
      const int j = lane % 8;
      lanes[lane] = (j / 4) * 16 + 4 * (j % 4) + c;
    }
    index[c] = _mm512_load_si512(lanes);
  }
  for (int b = 0; b < blocks; ++b) {
    const float* f[16];
    for (int l = 0; l < 16; ++l) f[l] = FirstTap(image, corner, bicubic, zeros, stride, 16 * b + l);
    float* o = out + size_t(b) * 16 * 16;
    for (int k = 0; k < 4; ++k) {
      const size_t row = size_t(k) * stride;
      __m512 reg[4];
      for (int g = 0; g < 4; ++g) {
        __m512 r = _mm512_castps128_ps512(_mm_loadu_ps(f[4 * g] + row));
        r = _mm512_insertf32x4(r, _mm_loadu_ps(f[4 * g + 1] + row), 1);
        r = _mm512_insertf32x4(r, _mm_loadu_ps(f[4 * g + 2] + row), 2);
        reg[g] = _mm512_insertf32x4(r, _mm_loadu_ps(f[4 * g + 3] + row), 3);
      }
      for (int c = 0; c < 4; ++c) {
        const __m512 lo = _mm512_permutex2var_ps(reg[0], index[c], reg[1]);
        const __m512 hi = _mm512_permutex2var_ps(reg[2], index[c], reg[3]);
        _mm512_storeu_ps(o + (4 * k + c) * 16, _mm512_mask_blend_ps(0xff00, lo, hi));
      }
    }
  }
}

// With AVX2: eight lanes at a time, per tap row each lane's four taps one 128-bit load;
// lanes j and j + 4 share a register, and a 4x4 transpose in each 128-bit half turns
// the four registers (lanes x columns) into one per column. The scalar loop's single
// loads and stores, 16 of each per lane, were most of the pre-warp's time on AVX2.
__attribute__((target("avx2"))) void GatherTapsAvx2(const float* image, const int64_t* corner,
                                                    const int32_t* bicubic, const float* zeros,
                                                    int stride, int blocks, float* __restrict out) {
  static_assert(kPrewarpLanes == 16);
  for (int b = 0; b < blocks; ++b) {
    float* o = out + size_t(b) * 16 * 16;
    for (int half = 0; half < 2; ++half) {
      const float* f[8];
      for (int j = 0; j < 8; ++j)
        f[j] = FirstTap(image, corner, bicubic, zeros, stride, 16 * b + 8 * half + j);
      for (int k = 0; k < 4; ++k) {
        const size_t row = size_t(k) * stride;
        __m256 r[4];
        for (int j = 0; j < 4; ++j) {
          r[j] = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(f[j] + row)),
                                      _mm_loadu_ps(f[j + 4] + row), 1);
        }
        const __m256 t0 = _mm256_unpacklo_ps(r[0], r[1]), t1 = _mm256_unpackhi_ps(r[0], r[1]);
        const __m256 t2 = _mm256_unpacklo_ps(r[2], r[3]), t3 = _mm256_unpackhi_ps(r[2], r[3]);
        float* col = o + size_t(4 * k) * 16 + 8 * half;
        _mm256_storeu_ps(col, _mm256_shuffle_ps(t0, t2, 0x44));
        _mm256_storeu_ps(col + 16, _mm256_shuffle_ps(t0, t2, 0xEE));
        _mm256_storeu_ps(col + 32, _mm256_shuffle_ps(t1, t3, 0x44));
        _mm256_storeu_ps(col + 48, _mm256_shuffle_ps(t1, t3, 0xEE));
      }
    }
  }
}

// Fills J: the neighbour sampled at A (m, 1), NaN where the bilinear quad leaves the
// image or holds a pixel without data (as the exact warp counts it); and its fixed
// point copy. J is interpolated bicubically where the 4x4 taps have data (else
// bilinearly): with bilinear J each level's sample would be blurred twice, and the
// finest windows lost accuracy (5x5 median error 13.5 mm against 12.6 mm for the exact
// warp on the synthetic dome).
void FillPrewarp(const KernelNeighbour& nb, SimdLevel simd, Prewarped* pw) {
  constexpr int kLanes = kPrewarpLanes;
  typedef float F16 __attribute__((vector_size(4 * kLanes)));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // J in float, NaN = no data (always on the margin); only its fixed point copy is kept.
  const int stride = pw->cols;
  Scratch value(size_t(pw->rows) * stride);
  std::fill(value.v.begin(), value.v.end(), nan);
  const double umax = nb.width - 1, vmax = nb.height - 1;
  const int i0 = kPrewarpMargin, i1 = pw->cols - kPrewarpMargin;
  // Per row, in blocks of kLanes J pixels: the neighbour pixel (u = -1 past the row's
  // end: outside), the 4x4 bicubic taps ([row][column][lane]), the fractions, whether
  // the pixel is in the image and has bicubic taps, the top left bilinear tap's index
  // and the bicubic value.
  const size_t padded = (size_t(std::max(0, i1 - i0)) + kLanes - 1) / kLanes * kLanes;
  std::vector<double> us(padded, -1.0), vs(padded, -1.0);
  std::vector<float> tap(16 * padded), ax(padded), ay(padded), cubic(padded);
  std::vector<int32_t> inside(padded), bicubic(padded);
  std::vector<int64_t> corner(padded);
  // What the lanes without bicubic taps read: four rows of zeros, nb.width apart.
  const std::vector<float> zero_rows(3 * size_t(nb.width) + 4, 0.0f);
  const float* zeros = zero_rows.data();
  for (int j = kPrewarpMargin; j < pw->rows - kPrewarpMargin; ++j) {
    float* row = value.data() + size_t(j) * stride;
    const double my = pw->oy + j;
    // The row's homography in one vectorizable pass (one reciprocal per pixel); u = -1
    // marks a point behind the neighbour.
    // (Everything in locals and restrict pointers, so that the stores cannot alias
    // the homography and the loop vectorizes; the same arithmetic.)
    const double bx = nb.a[0][1] * my + nb.a[0][2], by = nb.a[1][1] * my + nb.a[1][2];
    const double bz = nb.a[2][1] * my + nb.a[2][2];
    const double a00 = nb.a[0][0], a10 = nb.a[1][0], a20 = nb.a[2][0], ox = pw->ox;
    double* __restrict ur = us.data();
    double* __restrict vr = vs.data();
    for (int i = i0; i < i1; ++i) {
      const double mx = ox + i;
      const double qz = a20 * mx + bz;
      const double iz = 1.0 / qz;
      const bool front = qz > 0.0;
      ur[i - i0] = front ? (a00 * mx + bx) * iz : -1.0;
      vr[i - i0] = front ? (a10 * mx + by) * iz : -1.0;
    }
    // Sixteen J pixels at a time: the row's pixels are classified in one vectorized
    // pass, their taps gathered for the whole row (GatherTaps*), then the weights and
    // sums run on whole vectors (a generic vector type: one AVX-512 register, two AVX2
    // ones); gathering the row first keeps the vector loads from waiting on the stores
    // just before them. The expressions are those of the one-pixel code they replaced,
    // term for term, so J has the same bits; the bilinear fallback stays per pixel.
    const int blocks = int(padded) / kLanes;
    {
      // Branch-free and 32/64-bit types only, so that it vectorizes; outside lanes take
      // u = v = 0.
      const double* __restrict u_in = us.data();
      const double* __restrict v_in = vs.data();
      float* __restrict axr = ax.data();
      float* __restrict ayr = ay.data();
      int32_t* __restrict in_r = inside.data();
      int32_t* __restrict cubic_r = bicubic.data();
      int64_t* __restrict corner_r = corner.data();
      const int w = nb.width, h = nb.height;
      for (size_t l = 0; l < padded; ++l) {
        const double u0 = u_in[l], v0 = v_in[l];
        const bool in = (u0 >= 0.0) & (v0 >= 0.0) & (u0 < umax) & (v0 < vmax);
        const double u = in ? u0 : 0.0, v = in ? v0 : 0.0;
        const int xi = int(u), yi = int(v);
        axr[l] = float(u - xi);
        ayr[l] = float(v - yi);
        corner_r[l] = int64_t(yi) * w + xi;
        in_r[l] = in;
        cubic_r[l] = in & (xi >= 1) & (yi >= 1) & (xi + 2 < w) & (yi + 2 < h);
      }
    }
    if (simd == SimdLevel::kAvx512) {
      GatherTapsAvx512(nb.image, corner.data(), bicubic.data(), zeros, nb.width, blocks,
                       tap.data());
    } else if (simd == SimdLevel::kAvx2) {
      GatherTapsAvx2(nb.image, corner.data(), bicubic.data(), zeros, nb.width, blocks, tap.data());
    } else {
      GatherTapsScalar(nb.image, corner.data(), bicubic.data(), zeros, nb.width, blocks,
                       tap.data());
    }
    for (int b = 0; b < blocks; ++b) {
      const float* t = tap.data() + size_t(b) * 16 * kLanes;
      F16 vax, vay;
      std::memcpy(&vax, ax.data() + b * kLanes, sizeof(vax));
      std::memcpy(&vay, ay.data() + b * kLanes, sizeof(vay));
      F16 wx[4], wy[4];
      CubicWeights(vax, wx);
      CubicWeights(vay, wy);
      // Catmull-Rom where all 4x4 taps have data (a tap without data makes it NaN).
      F16 value = {};
      for (int k = 0; k < 4; ++k) {
        F16 t0, t1, t2, t3;
        std::memcpy(&t0, t + (4 * k + 0) * kLanes, sizeof(t0));
        std::memcpy(&t1, t + (4 * k + 1) * kLanes, sizeof(t1));
        std::memcpy(&t2, t + (4 * k + 2) * kLanes, sizeof(t2));
        std::memcpy(&t3, t + (4 * k + 3) * kLanes, sizeof(t3));
        value += wy[k] * (wx[0] * t0 + wx[1] * t1 + wx[2] * t2 + wx[3] * t3);
      }
      std::memcpy(cubic.data() + b * kLanes, &value, sizeof(value));
    }
    for (int l = 0; l < i1 - i0; ++l) {
      if (!inside[l]) continue;
      if (bicubic[l] && cubic[l] == cubic[l]) {
        row[i0 + l] = cubic[l];
        continue;
      }
      const float* p = nb.image + corner[l];
      const float top = p[0] + ax[l] * (p[1] - p[0]);
      const float bot = p[nb.width] + ax[l] * (p[nb.width + 1] - p[nb.width]);
      row[i0 + l] = top + ay[l] * (bot - top);
    }
  }
  // The fixed point copy, pair_ok and the row's facts, in passes that vectorize.
  pw->has_data.assign(pw->rows, 0);
  pw->q = Pool<int16_t>::Take(size_t(pw->rows) * pw->qstride);
  pw->pair_ok = Pool<int16_t>::Take(size_t(pw->rows) * pw->qstride);
  std::fill(pw->q.begin(), pw->q.end(), 0);
  std::fill(pw->pair_ok.begin(), pw->pair_ok.end(), 0);
  pw->ok_lo.assign(pw->rows, 1);
  pw->ok_hi.assign(pw->rows, 0);
  pw->ok_run.assign(pw->rows, 0);
  for (int j = 0; j < pw->rows; ++j) {
    const float* __restrict row = value.data() + size_t(j) * stride;
    int16_t* __restrict q = pw->q.data() + size_t(j) * pw->qstride;
    int16_t* __restrict ok = pw->pair_ok.data() + size_t(j) * pw->qstride;
    int valid = 0;
    for (int i = 0; i < pw->cols; ++i) {
      const float g = row[i];
      q[i] = g == g ? int16_t(std::clamp(g, 0.0f, 255.0f) * kQ + 0.5f) : 0;
      valid += g == g;
    }
    pw->has_data[j] = valid > 0;
    int count = 0;
    for (int i = 0; i + 1 < pw->cols; ++i) {
      const bool pair = (row[i] == row[i]) & (row[i + 1] == row[i + 1]);
      ok[i] = pair ? -1 : 0;
      count += pair;
    }
    // The first and last pair with data.
    int lo = -1, hi = -1;
    if (count > 0) {
      lo = 0;
      while (ok[lo] == 0) ++lo;
      hi = pw->cols - 2;
      while (ok[hi] == 0) --hi;
      pw->ok_lo[j] = lo;
      pw->ok_hi[j] = hi;
    }
    pw->ok_run[j] = lo < 0 || count == hi - lo + 1;  // no pair at all: an empty run
  }
}

// The AVX2 path's byte shuffles of the positions [p_begin, p_end) (multiples of 32) from
// their columns relative to the block (`rel`): per position, the bytes of its left tap
// among the 8 columns loaded from its group's first column, 2 r and 2 r + 1 for r = its
// column - the group's first column (at most 7), and per block whether a group's taps,
// right taps included, reach past those 8 columns (`scalar`: r above 6). Sixteen
// positions a step: a scalar loop over the positions took about a tenth of the AVX2
// kernel's time. A group's columns are non-decreasing (its pixels are consecutive), so
// its last position has the largest r.
__attribute__((target("avx2"))) void ShufflePatternAvx2(const int16_t* rel, int p_begin, int p_end,
                                                        uint8_t* shuffle, uint8_t* scalar) {
  // Per 128-bit lane, positions 0..3 and 4..7: each position takes its group's first.
  const __m256i first_of_group = _mm256_setr_epi8(0, 1, 0, 1, 0, 1, 0, 1, 8, 9, 8, 9, 8, 9, 8, 9, 0,
                                                  1, 0, 1, 0, 1, 0, 1, 8, 9, 8, 9, 8, 9, 8, 9);
  const __m256i seven = _mm256_set1_epi16(7), six = _mm256_set1_epi16(6);
  // 2 r | (2 r + 1) << 8 = 514 r + 256.
  const __m256i times = _mm256_set1_epi16(514), plus = _mm256_set1_epi16(256);
  for (int k = p_begin / 32; k < p_end / 32; ++k) {
    __m256i wide = _mm256_setzero_si256();
    for (int h = 32 * k; h < 32 * k + 32; h += 16) {
      const __m256i c = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(rel + h));
      const __m256i r = _mm256_sub_epi16(c, _mm256_shuffle_epi8(c, first_of_group));
      wide = _mm256_or_si256(wide, _mm256_cmpgt_epi16(r, six));
      const __m256i bytes =
          _mm256_add_epi16(_mm256_mullo_epi16(_mm256_min_epi16(r, seven), times), plus);
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(shuffle + 2 * h), bytes);
    }
    scalar[k] = !_mm256_testz_si256(wide, wide);
  }
}

// The fixed point column pattern of inverse depth w for `n32` positions (a multiple of
// 32), made over the positions [p_begin, p_end) (multiples of 32; the rest left as they
// were), for the loads of path `simd`. `pixel` holds the pixel of each position (pixels at
// and past the width repeating the last one) and `frac_scale` 32768 for pixels inside
// the width, else 0; `col` is scratch. Not inlined: every path runs this one copy.
__attribute__((noinline)) void MakePattern16(const Prewarped& pw, float w, int width, int n32,
                                             int p_begin, int p_end, SimdLevel simd,
                                             const double* pixel,
                                             const double* frac_scale, std::vector<int32_t>* col,
                                             LevelPattern16* pat) {
  pat->s = 1.0 / std::fma(double(w), pw.c[2], 1.0);
  pat->my0 = std::fma(pat->s * double(w), pw.c[1], -pw.oy);
  const double s = pat->s, mx0 = std::fma(pat->s * double(w), pw.c[0], -pw.ox);
  pat->mx0 = mx0;
  pat->base.resize(n32 / 32);
  pat->scalar.assign(n32 / 32, 0);
  pat->rel.resize(n32);
  pat->frac.resize(n32);
  col->resize(n32);
  int32_t* __restrict c = col->data();
  int16_t* __restrict f = pat->frac.data();
  int16_t* __restrict rel = pat->rel.data();
  const int last = pw.cols - 1;
  // Plain loops that vectorize.
  for (int p = p_begin; p < p_end; ++p) {
    const double mx = std::fma(s, pixel[p], mx0);
    const double fl = std::floor(mx);
    const int ci = int(fl);
    c[p] = ci < 0 ? 0 : (ci > last ? last : ci);
    const int fq = int((mx - fl) * frac_scale[p] + 0.5);
    f[p] = int16_t(fq > 32767 ? 32767 : fq);
  }
  for (int k = p_begin / 32; k < p_end / 32; ++k) {
    // Positions 0 and 31 hold the block's first and last pixels.
    const int32_t b = c[32 * k];
    pat->base[k] = b;
    if (simd == SimdLevel::kAvx512) pat->scalar[k] = c[32 * k + 31] + 1 - b > 63;
    for (int p = 32 * k; p < 32 * k + 32; ++p) rel[p] = int16_t(c[p] - b);
  }
  if (simd != SimdLevel::kAvx2) return;
  pat->shuffle.resize(2 * size_t(n32));
  ShufflePatternAvx2(rel, p_begin, p_end, pat->shuffle.data(), pat->scalar.data());
}

// J row and vertical fraction of reference row y (one copy for every path, as above).
__attribute__((noinline)) void PatternRow(const Prewarped& pw, const LevelPattern16& pat, int y,
                                          int* r, float* ay) {
  const double my = std::fma(pat.s, double(y), pat.my0);
  const double fl = std::floor(my);
  *r = std::clamp(int(fl), 0, pw.rows - 2);
  *ay = float(my - fl);
}

// (x f + 2^14) >> 15, as _mm256_mulhrs_epi16 and _mm512_mulhrs_epi16 round.
inline int16_t MulHrs(int x, int f) { return int16_t((x * f + (1 << 14)) >> 15); }

// One fixed point J row resampled at the level's pattern, in stored order, over the
// positions [x_begin, x_end) (multiples of 32): out = J(col + frac), and with kOk
// ok_out = pair_ok(col). Scalar; the SIMD paths' arithmetic is the same.
template <bool kOk>
void HorizontalRowQScalar(const int16_t* __restrict jrow, const int16_t* __restrict ok_row,
                          const LevelPattern16& pat, int x_begin, int x_end,
                          int16_t* __restrict out, int16_t* __restrict ok_out) {
  for (int i = x_begin; i < x_end; ++i) {
    const int c = pat.base[i / 32] + pat.rel[i];
    out[i] = int16_t(jrow[c] + MulHrs(jrow[c + 1] - jrow[c], pat.frac[i]));
    if constexpr (kOk) ok_out[i] = ok_row[c];
  }
}

// The same with AVX2, 16 positions per register. Per 128-bit lane, its two groups' 8
// columns each come from one unaligned load, and byte shuffles pick both taps of every
// position (the right tap two bytes after the left one). `next_row`: as for the
// AVX-512 path below.
template <bool kOk>
__attribute__((target("avx2,fma"), noinline)) void HorizontalRowQAvx2(
    const int16_t* __restrict jrow, const int16_t* __restrict ok_row, const LevelPattern16& pat,
    int x_begin, int x_end, int16_t* __restrict out, int16_t* __restrict ok_out, int next_row) {
  const __m256i two = _mm256_set1_epi8(2);
  // Lane 0 from group offset r0, lane 1 from r1.
  const auto load2 = [](const int16_t* p, int r0, int r1) {
    return _mm256_inserti128_si256(
        _mm256_castsi128_si256(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p + r0))),
        _mm_loadu_si128(reinterpret_cast<const __m128i*>(p + r1)), 1);
  };
  for (int x = x_begin, k = x_begin / 32; x < x_end; x += 32, ++k) {
    if (pat.scalar[k]) {
      HorizontalRowQScalar<kOk>(jrow, ok_row, pat, x, x + 32, out, ok_out);
      continue;
    }
    const int b = pat.base[k];
    // The next reference row reads the next J row at about these columns.
    _mm_prefetch(reinterpret_cast<const char*>(jrow + next_row + b), _MM_HINT_T0);
    _mm_prefetch(reinterpret_cast<const char*>(jrow + next_row + b + 32), _MM_HINT_T0);
    for (int h = x; h < x + 32; h += 16) {
      const int16_t* rel = pat.rel.data() + h;
      // First groups of the lanes (bytes 0..7) and second groups (bytes 8..15).
      const __m256i first = load2(jrow + b, rel[0], rel[8]);
      const __m256i second = load2(jrow + b, rel[4], rel[12]);
      const __m256i sa =
          _mm256_loadu_si256(reinterpret_cast<const __m256i*>(pat.shuffle.data() + 2 * h));
      const __m256i sc = _mm256_add_epi8(sa, two);
      const __m256i a =
          _mm256_blend_epi32(_mm256_shuffle_epi8(first, sa), _mm256_shuffle_epi8(second, sa), 0xCC);
      const __m256i c =
          _mm256_blend_epi32(_mm256_shuffle_epi8(first, sc), _mm256_shuffle_epi8(second, sc), 0xCC);
      const __m256i f = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(pat.frac.data() + h));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + h),
                          _mm256_add_epi16(a, _mm256_mulhrs_epi16(_mm256_sub_epi16(c, a), f)));
      if constexpr (kOk) {
        const __m256i ok_first = load2(ok_row + b, rel[0], rel[8]);
        const __m256i ok_second = load2(ok_row + b, rel[4], rel[12]);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(ok_out + h),
                            _mm256_blend_epi32(_mm256_shuffle_epi8(ok_first, sa),
                                               _mm256_shuffle_epi8(ok_second, sa), 0xCC));
      }
    }
  }
}

// The same with AVX-512, 32 positions per register: one pair of loads and two
// permutes serve both taps of all 32 positions. `next_row`: the offset of the next J
// row (0 for the last), whose columns are prefetched for the next reference row.
template <bool kOk>
__attribute__((target("avx512f,avx512bw,fma"), noinline)) void HorizontalRowQAvx512(
    const int16_t* __restrict jrow, const int16_t* __restrict ok_row, const LevelPattern16& pat,
    int x_begin, int x_end, int16_t* __restrict out, int16_t* __restrict ok_out, int next_row) {
  const __m512i one = _mm512_set1_epi16(1);
  for (int x = x_begin, k = x_begin / 32; x < x_end; x += 32, ++k) {
    const int b = pat.base[k];
    if (pat.scalar[k]) {
      HorizontalRowQScalar<kOk>(jrow, ok_row, pat, x, x + 32, out, ok_out);
      continue;
    }
    const __m512i rel = _mm512_loadu_si512(pat.rel.data() + x);
    // The next reference row reads the next J row at about these columns.
    _mm_prefetch(reinterpret_cast<const char*>(jrow + next_row + b), _MM_HINT_T0);
    _mm_prefetch(reinterpret_cast<const char*>(jrow + next_row + b + 32), _MM_HINT_T0);
    const __m512i lo = _mm512_loadu_si512(jrow + b), hi = _mm512_loadu_si512(jrow + b + 32);
    const __m512i a = _mm512_permutex2var_epi16(lo, rel, hi);
    const __m512i c = _mm512_permutex2var_epi16(lo, _mm512_add_epi16(rel, one), hi);
    const __m512i f = _mm512_loadu_si512(pat.frac.data() + x);
    _mm512_storeu_si512(out + x,
                        _mm512_add_epi16(a, _mm512_mulhrs_epi16(_mm512_sub_epi16(c, a), f)));
    if constexpr (kOk) {
      _mm512_storeu_si512(ok_out + x,
                          _mm512_permutex2var_epi16(_mm512_loadu_si512(ok_row + b), rel,
                                                    _mm512_loadu_si512(ok_row + b + 32)));
    }
  }
}

// One neighbour's part of a reference row in the fixed point paths (VerticalSsdQ*): its
// resampled J rows above and below (stored order), the vertical fraction (Q15), and
// where its samples have data: pixels lo..hi when ok_top is null (J rows without
// holes: the pattern reads their pairs with data over one run of pixels), else where
// both pair_ok rows ok_top and ok_bottom (stored order) say so.
struct QRow {
  const int16_t* top = nullptr;
  const int16_t* bottom = nullptr;
  const int16_t* ok_top = nullptr;
  const int16_t* ok_bottom = nullptr;
  int lo = 0, hi = -1;
  int16_t ay = 0;
};

// The SSD of one reference row over the neighbours rows[0..nn) in fixed point.
// Differences are grey x kQ (v = top + MulHrs(bottom - top, ay), d = v - ref); a sample
// without data differs by d_out. The squares sum exactly in 32 bits, and
// ssd[x] = fma(float(sum), scale, base) for the pixels x < width of the positions
// [x_begin, x_end) (multiples of 32): the SIMD paths give the same bits (scalar; `pixel`
// holds the pixel of each stored position).
void VerticalSsdQScalar(const QRow* rows, int nn, float base, const int16_t* __restrict ref_q,
                        int16_t d_out, float scale, int width, int x_begin, int x_end,
                        const int16_t* pixel, float* __restrict ssd) {
  for (int x = x_begin; x < x_end; x += 32) {
    int32_t acc[32] = {};
    for (int n = 0; n < nn; ++n) {
      const QRow& row = rows[n];
      for (int i = 0; i < 32; ++i) {
        const int p = x + i;
        const bool ok = row.ok_top ? (row.ok_top[p] & row.ok_bottom[p]) != 0
                                   : pixel[p] >= row.lo && pixel[p] <= row.hi;
        int d = d_out;
        if (ok) {
          const int v = int16_t(row.top[p] + MulHrs(row.bottom[p] - row.top[p], row.ay));
          d = int16_t(v - ref_q[p]);
        }
        acc[i] += d * d;
      }
    }
    for (int i = 0; i < 32; ++i) {
      if (pixel[x + i] < width) ssd[pixel[x + i]] = std::fma(float(acc[i]), scale, base);
    }
  }
}

// 16 differences of one neighbour against the reference r at positions h..h + 15 of
// the block of pixels [x, last] (AVX2).
__attribute__((target("avx2,fma"))) inline __attribute__((always_inline)) __m256i DiffQAvx2(
    const QRow& row, int h, int x, int last, __m256i r, __m256i out, const int16_t* pixel) {
  const __m256i t = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(row.top + h));
  const __m256i b = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(row.bottom + h));
  const __m256i v =
      _mm256_add_epi16(t, _mm256_mulhrs_epi16(_mm256_sub_epi16(b, t), _mm256_set1_epi16(row.ay)));
  const __m256i d = _mm256_sub_epi16(v, r);
  if (!row.ok_top) {
    if (row.lo <= x && last <= row.hi) return d;
    // lo <= p <= hi as signed compares (pixels are below 2^15 - 32).
    const __m256i p = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(pixel + h));
    const __m256i in =
        _mm256_and_si256(_mm256_cmpgt_epi16(p, _mm256_set1_epi16(int16_t(row.lo - 1))),
                         _mm256_cmpgt_epi16(_mm256_set1_epi16(int16_t(row.hi + 1)), p));
    return _mm256_blendv_epi8(out, d, in);
  }
  const __m256i ok =
      _mm256_and_si256(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(row.ok_top + h)),
                       _mm256_loadu_si256(reinterpret_cast<const __m256i*>(row.ok_bottom + h)));
  return _mm256_blendv_epi8(out, d, ok);
}

// VerticalSsdQScalar with AVX2. A block's positions 0..15 hold pixels 0..7 and 16..23,
// positions 16..31 pixels 8..15 and 24..31: per register, the unpacks of two
// neighbours' differences square and sum into those pixels in order.
__attribute__((target("avx2,fma"))) void VerticalSsdQAvx2(const QRow* rows, int nn, float base,
                                                          const int16_t* __restrict ref_q,
                                                          int16_t d_out, float scale, int width,
                                                          int x_begin, int x_end,
                                                          const int16_t* pixel,
                                                          float* __restrict ssd) {
  const __m256i out = _mm256_set1_epi16(d_out);
  const __m256 vscale = _mm256_set1_ps(scale), vbase = _mm256_set1_ps(base);
  for (int x = x_begin; x < x_end; x += 32) {
    // Positions past the width hold anything: their sums are never read.
    const int last = std::min(x + 31, width - 1);
    const __m256i r0 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(ref_q + x));
    const __m256i r1 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(ref_q + x + 16));
    __m256i acc0 = _mm256_setzero_si256(), acc1 = acc0, acc2 = acc0, acc3 = acc0;
    for (int n = 0; n < nn; n += 2) {
      __m256i dn0 = out, dn1 = out, dm0 = _mm256_setzero_si256(), dm1 = dm0;
      const QRow& rn = rows[n];
      if (rn.ok_top || (rn.hi >= x && rn.lo <= last)) {  // else no data in the block
        dn0 = DiffQAvx2(rn, x, x, last, r0, out, pixel);
        dn1 = DiffQAvx2(rn, x + 16, x, last, r1, out, pixel);
      }
      if (n + 1 < nn) {
        const QRow& rm = rows[n + 1];
        dm0 = dm1 = out;
        if (rm.ok_top || (rm.hi >= x && rm.lo <= last)) {
          dm0 = DiffQAvx2(rm, x, x, last, r0, out, pixel);
          dm1 = DiffQAvx2(rm, x + 16, x, last, r1, out, pixel);
        }
      }
      const __m256i lo0 = _mm256_unpacklo_epi16(dn0, dm0), hi0 = _mm256_unpackhi_epi16(dn0, dm0);
      const __m256i lo1 = _mm256_unpacklo_epi16(dn1, dm1), hi1 = _mm256_unpackhi_epi16(dn1, dm1);
      acc0 = _mm256_add_epi32(acc0, _mm256_madd_epi16(lo0, lo0));  // pixels 0..7
      acc1 = _mm256_add_epi32(acc1, _mm256_madd_epi16(hi0, hi0));  // 16..23
      acc2 = _mm256_add_epi32(acc2, _mm256_madd_epi16(lo1, lo1));  // 8..15
      acc3 = _mm256_add_epi32(acc3, _mm256_madd_epi16(hi1, hi1));  // 24..31
    }
    _mm256_storeu_ps(ssd + x, _mm256_fmadd_ps(_mm256_cvtepi32_ps(acc0), vscale, vbase));
    _mm256_storeu_ps(ssd + x + 8, _mm256_fmadd_ps(_mm256_cvtepi32_ps(acc2), vscale, vbase));
    _mm256_storeu_ps(ssd + x + 16, _mm256_fmadd_ps(_mm256_cvtepi32_ps(acc1), vscale, vbase));
    _mm256_storeu_ps(ssd + x + 24, _mm256_fmadd_ps(_mm256_cvtepi32_ps(acc3), vscale, vbase));
  }
}

// 32 differences of one neighbour against the reference r at the block of pixels
// [x, last] (AVX-512).
__attribute__((target("avx512f,avx512bw,fma"))) inline __attribute__((always_inline)) __m512i
DiffQAvx512(const QRow& row, int x, int last, __m512i r, __m512i out, const int16_t* pixel) {
  if (!row.ok_top && (row.hi < x || row.lo > last)) return out;  // no data in the block
  const __m512i t = _mm512_loadu_si512(row.top + x), b = _mm512_loadu_si512(row.bottom + x);
  const __m512i v =
      _mm512_add_epi16(t, _mm512_mulhrs_epi16(_mm512_sub_epi16(b, t), _mm512_set1_epi16(row.ay)));
  const __m512i d = _mm512_sub_epi16(v, r);
  if (!row.ok_top) {
    if (row.lo <= x && last <= row.hi) return d;
    const __m512i p = _mm512_loadu_si512(pixel + x);
    const __mmask32 in = _mm512_cmpge_epi16_mask(p, _mm512_set1_epi16(int16_t(row.lo))) &
                         _mm512_cmple_epi16_mask(p, _mm512_set1_epi16(int16_t(row.hi)));
    return _mm512_mask_mov_epi16(out, in, d);
  }
  const __m512i ok =
      _mm512_and_si512(_mm512_loadu_si512(row.ok_top + x), _mm512_loadu_si512(row.ok_bottom + x));
  return _mm512_ternarylogic_epi32(ok, d, out, 0xCA);  // ok ? d : out
}

// VerticalSsdQScalar with AVX-512: per 128-bit lane L, the unpacks of two neighbours'
// differences square and sum into pixels 4 L..4 L + 3 (low) and 16 + 4 L.. (high).
__attribute__((target("avx512f,avx512bw,fma"))) void VerticalSsdQAvx512(
    const QRow* rows, int nn, float base, const int16_t* __restrict ref_q, int16_t d_out,
    float scale, int width, int x_begin, int x_end, const int16_t* pixel,
    float* __restrict ssd) {
  const __m512i out = _mm512_set1_epi16(d_out);
  const __m512 vscale = _mm512_set1_ps(scale), vbase = _mm512_set1_ps(base);
  for (int x = x_begin; x < x_end; x += 32) {
    // Positions past the width hold anything: their sums are never read.
    const int last = std::min(x + 31, width - 1);
    const __m512i r = _mm512_loadu_si512(ref_q + x);
    __m512i acc_lo = _mm512_setzero_si512(), acc_hi = _mm512_setzero_si512();
    for (int n = 0; n < nn; n += 2) {
      const __m512i dn = DiffQAvx512(rows[n], x, last, r, out, pixel);
      const __m512i dm =
          n + 1 < nn ? DiffQAvx512(rows[n + 1], x, last, r, out, pixel) : _mm512_setzero_si512();
      const __m512i lo = _mm512_unpacklo_epi16(dn, dm), hi = _mm512_unpackhi_epi16(dn, dm);
      acc_lo = _mm512_add_epi32(acc_lo, _mm512_madd_epi16(lo, lo));
      acc_hi = _mm512_add_epi32(acc_hi, _mm512_madd_epi16(hi, hi));
    }
    _mm512_storeu_ps(ssd + x, _mm512_fmadd_ps(_mm512_cvtepi32_ps(acc_lo), vscale, vbase));
    _mm512_storeu_ps(ssd + x + 16, _mm512_fmadd_ps(_mm512_cvtepi32_ps(acc_hi), vscale, vbase));
  }
}

// The pixels lo..hi of a row whose pattern column (floor(s x + mx0), as MakePattern16
// computes it, monotone in x) lies in [c_lo, c_hi]; lo > hi when none.
void PixelRun(const LevelPattern16& pat, int width, int c_lo, int c_hi, int* lo, int* hi) {
  const double s = pat.s, mx0 = pat.mx0;
  const auto col = [&](int x) { return int(std::floor(std::fma(s, double(x), mx0))); };
  // The first x with col(x) >= c: from the inverse, then corrected by the exact
  // expression so that rounding cannot move it.
  const auto first = [&](int c) {
    int x = int(std::clamp(std::ceil((c - mx0) / s), 0.0, double(width)));
    while (x > 0 && col(x - 1) >= c) --x;
    while (x < width && col(x) < c) ++x;
    return x;
  };
  *lo = first(c_lo);
  *hi = first(c_hi + 1) - 1;
}

// Everything a band needs besides its own buffers.
struct Prepared {
  int stride = 0;              // width rounded up to the path's lanes (8, 16; 32 in fixed point)
  std::vector<float> ref_neg;  // minus the reference grey, rows x stride
  std::vector<std::vector<uint32_t>> taps;  // per neighbour (SIMD paths only)
  std::vector<bool> holes;                  // per neighbour: has pixels without data
  std::vector<Prewarped> prewarped;         // per neighbour (pre-warped paths only)
  std::vector<int16_t> ref_q;               // pre-warped paths: the reference grey x kQ,
                                            // rows x stride, stored order
  int16_t d_out = 0;                        // its difference of a sample without data
};

// The band loop, instantiated once per path; the SIMD instances sit inside functions
// with the matching target attribute, so the warp calls inline there.
enum class Path { kScalar, kAvx2, kAvx512, kPrewarpScalar, kPrewarpAvx2, kPrewarpAvx512 };

template <Path kPath>
inline __attribute__((always_inline)) void RunBandsImpl(const KernelInput& in, const Prepared& prep,
                                                        int64_t band_begin, int64_t band_end,
                                                        std::vector<KernelOutput>* outputs) {
  const int width = in.width, height = in.height, stride = prep.stride;
  const int nwin = static_cast<int>(in.half_windows.size());
  const int hmax = *std::max_element(in.half_windows.begin(), in.half_windows.end());
  Scratch ssd(size_t(kBandRows + 2 * hmax) * stride);
  std::vector<float> vsum(stride), cost(stride);
  std::vector<BandState> states(nwin);
  // Per window, the band's costs of the levels that wait for the group's last one
  // (kLevelGroup - 1 of them).
  std::vector<Scratch> pending(size_t(nwin) * (kLevelGroup - 1));
  for (auto& p : pending) p.v.resize(size_t(kBandRows) * stride);
  // The SSD rows a band shares with the next one (its last 2 hmax rows), per level:
  // bands run in order on this thread, so the next band copies them instead of warping
  // them again (at window 7 that is 6 rows in 38).
  const int halo = 2 * hmax;
  // Up to 64 MB per thread; beyond that (large images, many levels, wide windows) the
  // shared rows are warped twice.
  // Not with per-tile levels: bands then search different levels.
  const bool ranged = !in.tile_lo.empty();
  const bool keep_halo =
      !ranged && size_t(halo) * stride * in.num_levels <= (size_t(1) << 24);
  const int tiles_x = (width + kKernelTilePx - 1) / kKernelTilePx;
  // Per level, the runs of pixels [pa, pb) of the band's row whose levels are in the same
  // place of their group of kLevelGroup: the whole row, or with per-tile levels,
  // adjacent tiles that have the level at the same place (their first level and
  // last level decide it).
  struct Segment {
    int pa, pb, g;
    bool last;  // the group ends at this level: the state is updated
  };
  std::vector<Segment> segments;
  Scratch halo_cache(keep_halo ? size_t(halo) * stride * in.num_levels : 0);
  // Pre-warped paths: the column pattern of each neighbour at the current level, the
  // resampled J rows and pair_ok rows in two slots per neighbour (by row parity) and
  // the J row each holds, and whether a slot's row is a run.
  constexpr bool kFixed =
      kPath == Path::kPrewarpScalar || kPath == Path::kPrewarpAvx2 || kPath == Path::kPrewarpAvx512;
  constexpr SimdLevel kPatternSimd = kPath == Path::kPrewarpAvx512 ? SimdLevel::kAvx512
                                     : kPath == Path::kPrewarpAvx2 ? SimdLevel::kAvx2
                                                                   : SimdLevel::kNone;
  const int nn = static_cast<int>(prep.prewarped.size());
  std::vector<int> slot_row(2 * nn, -1);
  const int n32 = (width + 31) / 32 * 32;
  std::vector<LevelPattern16> patterns16(kFixed ? nn : 0);
  std::vector<int32_t> pattern_col;
  std::vector<double> position_pixel(kFixed ? n32 : 0), position_frac_scale(kFixed ? n32 : 0);
  std::vector<int16_t> position_x(kFixed ? n32 : 0);  // the pixel of each stored position
  for (int p = 0; p < (kFixed ? n32 : 0); ++p) {
    const int x = p / 32 * 32 + StoredPixel(p % 32);
    position_x[p] = int16_t(x);
    position_pixel[p] = std::min(x, width - 1);
    position_frac_scale[p] = x < width ? 32768.0 : 0.0;
  }
  std::vector<int16_t> qrows(kFixed ? size_t(2 * nn) * n32 : 0);
  std::vector<int16_t> qoks(kFixed ? size_t(2 * nn) * n32 : 0);
  std::vector<int> slot_lo(2 * nn), slot_hi(2 * nn);  // a run slot's pixels with data
  std::vector<uint8_t> slot_masked(2 * nn), slot_ok_filled(2 * nn);
  std::vector<QRow> qrow(nn);
  // Per neighbour, the last PixelRun of this level: J columns c_lo..c_hi -> pixels lo..hi.
  struct RunMemo {
    int c_lo = 0, c_hi = -1, lo = 0, hi = -1;
  };
  std::vector<RunMemo> run_memo(nn);
  const float q_scale = 1.0f / float(kQ * kQ);
  int cached_end = -1;  // the halo cache holds rows [cached_end - halo, cached_end)
  for (int64_t band = band_begin; band < band_end; ++band) {
    const int y0 = static_cast<int>(band) * kBandRows;
    const int y1 = std::min(height, y0 + kBandRows);
    const int s0 = std::max(0, y0 - hmax), s1 = std::min(height, y1 + hmax);
    // Rows [s0, c1) come from the cache when the previous band left them there.
    const int c1 = cached_end == std::min(height, y0 + hmax) ? cached_end : s0;
    // The rows this band leaves for the next one.
    const int n0 = std::max(s0, s1 - halo);
    for (auto& s : states) s.Reset(size_t(y1 - y0) * stride);
    const int* tile_lo = ranged ? in.tile_lo.data() + band * tiles_x : nullptr;
    const int* tile_hi = ranged ? in.tile_hi.data() + band * tiles_x : nullptr;
    int band_lo = 0, band_hi = in.num_levels - 1;
    if (ranged) {
      band_lo = in.num_levels, band_hi = -1;
      for (int t = 0; t < tiles_x; ++t) {
        if (tile_lo[t] > tile_hi[t]) continue;
        band_lo = std::min(band_lo, tile_lo[t]);
        band_hi = std::max(band_hi, tile_hi[t]);
      }
    }
    for (int l = band_lo; l <= band_hi; ++l) {
      // The columns whose SSD this level needs, [span_lo, span_hi): every pixel, or the
      // tiles that have the level and their window margin.
      int span_lo = 0, span_hi = width;
      segments.clear();
      if (ranged) {
        int first = -1, last = -1;
        for (int t = 0; t < tiles_x; ++t) {
          if (tile_lo[t] > l || l > tile_hi[t]) continue;
          if (first < 0) first = t;
          last = t;
          const int g = (l - tile_lo[t]) % kLevelGroup;
          const bool end = g + 1 == kLevelGroup || l == tile_hi[t];
          const int pa = t * kKernelTilePx, pb = std::min(width, pa + kKernelTilePx);
          if (!segments.empty() && segments.back().pb == pa && segments.back().g == g &&
              segments.back().last == end) {
            segments.back().pb = pb;
          } else {
            segments.push_back({pa, pb, g, end});
          }
        }
        if (first < 0) continue;  // no tile of the band has this level
        span_lo = std::max(0, first * kKernelTilePx - hmax);
        span_hi = std::min(width, (last + 1) * kKernelTilePx + hmax);
      } else {
        const int g = l % kLevelGroup;
        segments.push_back({0, width, g, g + 1 == kLevelGroup || l + 1 == in.num_levels});
      }
      // The same span in the pre-warped paths' blocks of 32 positions.
      const int q_begin = span_lo / 32 * 32, q_end = std::min(n32, (span_hi + 31) / 32 * 32);
      // The product is exact in double, so a contracted multiply-add (which the SIMD
      // instances may use and the scalar one not) rounds the same: one w for every path.
      const float w = float(double(in.w_far) + double(l) * double(in.w_step));
      float* cache = keep_halo ? halo_cache.data() + size_t(halo) * stride * l : nullptr;
      if constexpr (kFixed) {
        for (int n = 0; n < nn; ++n) {
          MakePattern16(prep.prewarped[n], w, width, n32, q_begin, q_end, kPatternSimd,
                        position_pixel.data(),
                        position_frac_scale.data(), &pattern_col, &patterns16[n]);
          run_memo[n] = RunMemo{1, -1, 0, -1};  // matches no row: ok_lo <= ok_hi or (1, 0)
        }
        std::fill(slot_row.begin(), slot_row.end(), -1);
      }
      if (c1 > s0) {
        std::copy(cache + size_t(s0 - (c1 - halo)) * stride, cache + size_t(halo) * stride,
                  ssd.data());
      }
      // Row by row, all neighbours: the row stays in L1 while they add to it.
      for (int y = c1; y < s1; ++y) {
        float* row = ssd.data() + size_t(y - s0) * stride;
        if constexpr (kFixed) {
          // Reference row y reads J rows r and r + 1 of each neighbour, resampled along
          // x once per level and kept in the slot of their parity (r grows with y). A
          // neighbour whose two rows have no data at all (the row falls outside its
          // image at this depth, often at near levels) adds the outside cost everywhere.
          // A J row without holes has data over one run of the row's pixels, found from
          // the pattern; only rows with holes resample their pair_ok row as well.
          int active = 0;
          float base_cost = 0.0f;
          for (int n = 0; n < nn; ++n) {
            const Prewarped& pw = prep.prewarped[n];
            const LevelPattern16& pat = patterns16[n];
            int r;
            float fy;
            PatternRow(pw, pat, y, &r, &fy);
            if (!pw.has_data[r] && !pw.has_data[r + 1]) {
              base_cost += in.outside_cost;
              continue;
            }
            QRow& q = qrow[active];
            const int fq = int(fy * 32768.0f + 0.5f);
            q.ay = int16_t(fq > 32767 ? 32767 : fq);
            q.lo = 0, q.hi = width - 1;
            bool masked = false;
            for (int j = r; j <= r + 1; ++j) {
              const int slot = 2 * n + (j & 1);
              if (slot_row[slot] != j) {
                const bool run = pw.ok_run[j];
                int x_begin = q_begin, x_end = q_end;
                if (run) {
                  // Only the blocks that hold pixels with data.
                  // Neighbouring J rows mostly share their run of columns with data.
                  RunMemo& m = run_memo[n];
                  if (m.c_lo != pw.ok_lo[j] || m.c_hi != pw.ok_hi[j]) {
                    m.c_lo = pw.ok_lo[j], m.c_hi = pw.ok_hi[j];
                    PixelRun(pat, width, m.c_lo, m.c_hi, &m.lo, &m.hi);
                  }
                  slot_lo[slot] = m.lo, slot_hi[slot] = m.hi;
                  x_begin = std::max(q_begin, slot_lo[slot] / 32 * 32);
                  x_end = std::min(q_end, (slot_hi[slot] / 32 + 1) * 32);
                  if (slot_lo[slot] > slot_hi[slot] || x_end < x_begin) x_end = x_begin;
                }
                const int16_t* jrow = pw.q.data() + size_t(j) * pw.qstride;
                const int16_t* ok_row = pw.pair_ok.data() + size_t(j) * pw.qstride;
                int16_t* out = qrows.data() + size_t(slot) * n32;
                int16_t* ok_out = qoks.data() + size_t(slot) * n32;
                if constexpr (kPath == Path::kPrewarpAvx512) {
                  (run ? HorizontalRowQAvx512<false>
                       : HorizontalRowQAvx512<true>)(jrow, ok_row, pat, x_begin, x_end, out, ok_out,
                                                     j + 1 < pw.rows ? pw.qstride : 0);
                } else if constexpr (kPath == Path::kPrewarpAvx2) {
                  (run ? HorizontalRowQAvx2<false>
                       : HorizontalRowQAvx2<true>)(jrow, ok_row, pat, x_begin, x_end, out, ok_out,
                                                   j + 1 < pw.rows ? pw.qstride : 0);
                } else {
                  (run ? HorizontalRowQScalar<false>
                       : HorizontalRowQScalar<true>)(jrow, ok_row, pat, x_begin, x_end, out,
                                                     ok_out);
                }
                slot_row[slot] = j;
                slot_masked[slot] = !run;
                slot_ok_filled[slot] = !run;
              }
              (j == r ? q.top : q.bottom) = qrows.data() + size_t(slot) * n32;
              if (slot_masked[slot]) {
                masked = true;
              } else {
                q.lo = std::max(q.lo, slot_lo[slot]);
                q.hi = std::min(q.hi, slot_hi[slot]);
              }
            }
            q.ok_top = q.ok_bottom = nullptr;
            if (masked) {
              // Both rows as pair_ok rows; a run becomes one.
              for (int j = r; j <= r + 1; ++j) {
                const int slot = 2 * n + (j & 1);
                int16_t* ok = qoks.data() + size_t(slot) * n32;
                if (!slot_ok_filled[slot]) {
                  for (int p = 0; p < n32; ++p) {
                    ok[p] =
                        position_x[p] >= slot_lo[slot] && position_x[p] <= slot_hi[slot] ? -1 : 0;
                  }
                  slot_ok_filled[slot] = true;
                }
                (j == r ? q.ok_top : q.ok_bottom) = ok;
              }
            }
            ++active;
          }
          constexpr auto kVerticalSsd = kPath == Path::kPrewarpAvx512 ? VerticalSsdQAvx512
                                        : kPath == Path::kPrewarpAvx2 ? VerticalSsdQAvx2
                                                                      : VerticalSsdQScalar;
          kVerticalSsd(qrow.data(), active, base_cost, prep.ref_q.data() + size_t(y) * stride,
                       prep.d_out, q_scale, width, q_begin, q_end, position_x.data(), row);
          continue;
        }
        if constexpr (kPath != Path::kAvx512) std::fill(row, row + stride, 0.0f);
        for (size_t n = 0; n < in.neighbours.size(); ++n) {
          const KernelNeighbour& nb = in.neighbours[n];
          if constexpr (kPath == Path::kAvx512) {
            // The first neighbour stores its costs instead of adding them.
            const uint32_t* taps = prep.taps[n].data();
            const float* ref_neg = prep.ref_neg.data() + size_t(y) * stride;
            const bool holes = prep.holes[n];
            if (n == 0) {
              (holes ? AccumulateRowAvx512<true, true>
                     : AccumulateRowAvx512<true, false>)(nb, taps, w, y, stride, ref_neg,
                                                         in.outside_cost, row);
            } else {
              (holes ? AccumulateRowAvx512<false, true>
                     : AccumulateRowAvx512<false, false>)(nb, taps, w, y, stride, ref_neg,
                                                          in.outside_cost, row);
            }
          } else if constexpr (kPath == Path::kAvx2) {
            AccumulateRowAvx2(nb, prep.taps[n].data(), w, y, stride,
                              prep.ref_neg.data() + size_t(y) * stride, in.outside_cost, row);
          } else {
            AccumulateRowScalar(nb, w, y, width, in.reference + size_t(y) * width, in.outside_cost,
                                row);
          }
        }
      }
      if (keep_halo && s1 - n0 == halo) {
        std::copy(ssd.data() + size_t(n0 - s0) * stride, ssd.data() + size_t(s1 - s0) * stride,
                  cache);
      }
      for (int k = 0; k < nwin; ++k) {
        const int h = in.half_windows[k];
        const int oy0 = std::max(y0, h), oy1 = std::min(y1, height - h);
        if (oy0 >= oy1 || width <= 2 * h) continue;
        BandState& st = states[k];
        // Vertical running sum over rows oy-h..oy+h, over the columns the segments' windows
        // read.
        const int vx0 = std::max(0, segments.front().pa - h);
        const int vx1 = std::min(width, segments.back().pb + h);
        std::fill(vsum.begin() + vx0, vsum.begin() + vx1, 0.0f);
        for (int yy = oy0 - h; yy <= oy0 + h; ++yy) {
          const float* row = ssd.data() + size_t(yy - s0) * stride;
          for (int x = vx0; x < vx1; ++x) vsum[x] += row[x];
        }
        for (int y = oy0; y < oy1; ++y) {
          if (y > oy0) {
            const float* add = ssd.data() + size_t(y + h - s0) * stride;
            const float* sub = ssd.data() + size_t(y - h - 1 - s0) * stride;
            for (int x = vx0; x < vx1; ++x) vsum[x] += add[x] - sub[x];
          }
          for (const Segment& seg : segments) {
            // Pixels whose window lies inside the image.
            const int pa = std::max(seg.pa, h), pb = std::min(seg.pb, width - h);
            if (pa >= pb) continue;
            const int n = pb - pa;
            const size_t o = size_t(y - y0) * stride + pa;
            // Levels go to the state in groups of kLevelGroup: the costs of the group's
            // earlier levels wait in `pending`.
            const int g = seg.g;
            if (!seg.last) {
              WindowSum(vsum.data() + pa - h, n, h,
                        pending[size_t(k) * (kLevelGroup - 1) + g].data() + o);
              continue;
            }
            const float* group[kLevelGroup];
            for (int i = 0; i < g; ++i) {
              group[i] = pending[size_t(k) * (kLevelGroup - 1) + i].data() + o;
            }
            WindowSum(vsum.data() + pa - h, n, h, cost.data());
            group[g] = cost.data();
            kUpdateRow[g](group, n, float(l - g), st.best.data() + o, st.level.data() + o,
                          st.cm.data() + o, st.cp.data() + o, st.before.data() + o,
                          st.after.data() + o, st.run.data() + o, st.run_prev.data() + o,
                          st.prev.data() + o);
          }
        }
      }
    }
    cached_end = keep_halo && s1 - n0 == halo ? s1 : -1;
    // Write the band's results.
    for (int k = 0; k < nwin; ++k) {
      const BandState& st = states[k];
      KernelOutput& out = (*outputs)[k];
      const int h = in.half_windows[k];
      for (int y = y0; y < y1; ++y) {
        for (int x = 0; x < width; ++x) {
          const size_t i = size_t(y - y0) * stride + x;
          const size_t g = size_t(y) * width + x;
          if (y < h || y >= height - h || x < h || x >= width - h) {
            out.best_level[g] = -1.0f;
            continue;
          }
          const float cm = st.cm[i], cb = st.best[i], cp = st.cp[i];
          const float curv = cm - 2.0f * cb + cp;
          out.best_level[g] = st.level[i];
          out.best_cost[g] = cb;
          out.second_cost[g] = std::min(st.before[i], st.after[i]);
          const bool ok = std::isfinite(curv) && curv > 0.0f;
          out.curvature[g] = ok ? curv : 0.0f;
          float off = ok ? 0.5f * (cm - cp) / curv : 0.0f;
          out.offset[g] = std::clamp(off, -0.5f, 0.5f);
        }
      }
    }
  }
}

void RunBandsScalar(const KernelInput& in, const Prepared& prep, int64_t b, int64_t e,
                    std::vector<KernelOutput>* outputs) {
  RunBandsImpl<Path::kScalar>(in, prep, b, e, outputs);
}

__attribute__((target("avx2,fma"))) void RunBandsAvx2(const KernelInput& in, const Prepared& prep,
                                                      int64_t b, int64_t e,
                                                      std::vector<KernelOutput>* outputs) {
  RunBandsImpl<Path::kAvx2>(in, prep, b, e, outputs);
}

__attribute__((target("avx512f,avx512bw,fma"))) void RunBandsAvx512(
    const KernelInput& in, const Prepared& prep, int64_t b, int64_t e,
    std::vector<KernelOutput>* outputs) {
  RunBandsImpl<Path::kAvx512>(in, prep, b, e, outputs);
}

void RunBandsPrewarpScalar(const KernelInput& in, const Prepared& prep, int64_t b, int64_t e,
                           std::vector<KernelOutput>* outputs) {
  RunBandsImpl<Path::kPrewarpScalar>(in, prep, b, e, outputs);
}

__attribute__((target("avx2,fma"))) void RunBandsPrewarpAvx2(const KernelInput& in,
                                                             const Prepared& prep, int64_t b,
                                                             int64_t e,
                                                             std::vector<KernelOutput>* outputs) {
  RunBandsImpl<Path::kPrewarpAvx2>(in, prep, b, e, outputs);
}

__attribute__((target("avx512f,avx512bw,fma"))) void RunBandsPrewarpAvx512(
    const KernelInput& in, const Prepared& prep, int64_t b, int64_t e,
    std::vector<KernelOutput>* outputs) {
  RunBandsImpl<Path::kPrewarpAvx512>(in, prep, b, e, outputs);
}

// Pre-warps every neighbour; false (and nothing set) when
// a neighbour's geometry does not suit it.
bool PreparePrewarp(const KernelInput& in, SimdLevel simd, int num_threads, Prepared* prep) {
  const size_t nn = in.neighbours.size();
  std::vector<Prewarped> pws(nn);
  const auto level_w = [&](int l) { return double(in.w_far) + double(l) * in.w_step; };
  std::vector<Reach> reaches;
  if (in.tile_lo.empty()) {
    const double w0 = in.w_far, w1 = level_w(in.num_levels - 1);
    reaches.push_back({0.0, 0.0, double(in.width - 1), double(in.height - 1), std::min(w0, w1),
                       std::max(w0, w1)});
  } else {
    // Only what the tiles search: each tile's pixels with the window margin its band's
    // SSD rows and columns take, over its own levels. A search bounded to a silhouette
    // resamples the neighbours where the silhouette can be seen, not the whole image.
    const int hmax = *std::max_element(in.half_windows.begin(), in.half_windows.end());
    const int tiles_x = (in.width + kKernelTilePx - 1) / kKernelTilePx;
    for (size_t t = 0; t < in.tile_lo.size(); ++t) {
      if (in.tile_lo[t] > in.tile_hi[t]) continue;
      const int tx = int(t % size_t(tiles_x)) * kKernelTilePx;
      const int ty = int(t / size_t(tiles_x)) * kKernelTilePx;
      const double w0 = level_w(in.tile_lo[t]), w1 = level_w(in.tile_hi[t]);
      reaches.push_back({double(std::max(0, tx - hmax)), double(std::max(0, ty - hmax)),
                         double(std::min(in.width - 1, tx + kKernelTilePx - 1 + hmax)),
                         double(std::min(in.height - 1, ty + kKernelTilePx - 1 + hmax)),
                         std::min(w0, w1), std::max(w0, w1)});
    }
    if (reaches.empty()) return false;
  }
  for (size_t n = 0; n < nn; ++n) {
    if (!PlanPrewarp(in.neighbours[n], in.width, in.height, reaches, &pws[n])) return false;
  }
  core::ParallelFor(0, int64_t(nn), num_threads, [&](int64_t b, int64_t e) {
    for (int64_t n = b; n < e; ++n) FillPrewarp(in.neighbours[n], simd, &pws[n]);
  });
  prep->prewarped = std::move(pws);
  return true;
}

}  // namespace

SimdLevel CostKernelSimd() {
  static const SimdLevel level = [] {
    SimdLevel cpu = SimdLevel::kNone;
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
        __builtin_cpu_supports("fma")) {
      cpu = SimdLevel::kAvx512;
    } else if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) {
      cpu = SimdLevel::kAvx2;
    }
    // DOME_MAX_SIMD (avx512, avx2 or scalar) holds every process on one machine to a
    // lower path: the paths give the same bits, so only the time changes (an older
    // CPU's kernel measured on a newer one, with a build for its instruction set).
    const char* cap = std::getenv("DOME_MAX_SIMD");
    if (cap == nullptr || *cap == '\0') return cpu;
    const std::string c = cap;
    core::Require(c == "avx512" || c == "avx2" || c == "scalar", "DOME_MAX_SIMD",
                  "must be avx512, avx2 or scalar, got '" + c + "'");
    const SimdLevel most = c == "avx512" ? SimdLevel::kAvx512
                           : c == "avx2" ? SimdLevel::kAvx2
                                         : SimdLevel::kNone;
    return std::min(cpu, most);
  }();
  return level;
}

void RunCostKernel(const KernelInput& input, int num_threads, std::vector<KernelOutput>* outputs) {
  if (!input.tile_lo.empty()) {
    const size_t tiles = size_t((input.width + kKernelTilePx - 1) / kKernelTilePx) *
                         size_t((input.height + kKernelTilePx - 1) / kKernelTilePx);
    core::Require(input.tile_lo.size() == tiles && input.tile_hi.size() == tiles,
                  "cost kernel: tile levels",
                  "expected " + std::to_string(tiles) + " tiles, got " +
                      std::to_string(input.tile_lo.size()) + " and " +
                      std::to_string(input.tile_hi.size()));
    for (size_t t = 0; t < tiles; ++t) {
      core::Require(input.tile_lo[t] > input.tile_hi[t] ||
                        (input.tile_lo[t] >= 0 && input.tile_hi[t] < input.num_levels),
                    "cost kernel: tile levels",
                    "tile " + std::to_string(t) + " has levels " +
                        std::to_string(input.tile_lo[t]) + ".." +
                        std::to_string(input.tile_hi[t]) + " outside 0.." +
                        std::to_string(input.num_levels - 1));
    }
  }
  SimdLevel simd = std::min(input.max_simd, CostKernelSimd());
  Prepared prep;
  // The fixed point sums of the pre-warped kernel hold up to kMaxQNeighbours neighbours
  // and differences up to 255 grey levels; its pixel columns are 16-bit.
  const bool fits_fixed = input.neighbours.size() <= size_t(kMaxQNeighbours) &&
                          input.outside_cost <= 255.0f * 255.0f && input.width < (1 << 15) - 32;
  const bool prewarp =
      input.prewarp && fits_fixed && PreparePrewarp(input, simd, num_threads, &prep);
  if (prewarp) {
    prep.stride = (input.width + 31) / 32 * 32;
    // The fixed point reference, in the pattern's stored order.
    prep.ref_q.assign(size_t(prep.stride) * input.height, 0);
    for (int y = 0; y < input.height; ++y) {
      const float* ref = input.reference + size_t(y) * input.width;
      int16_t* q = prep.ref_q.data() + size_t(y) * prep.stride;
      for (int p = 0; p < prep.stride; ++p) {
        const int x = p / 32 * 32 + StoredPixel(p % 32);
        if (x < input.width) q[p] = int16_t(std::lround(std::clamp(ref[x], 0.0f, 255.0f) * kQ));
      }
    }
    prep.d_out = int16_t(std::lround(std::sqrt(double(input.outside_cost)) * kQ));
  } else {
    for (const auto& nb : input.neighbours) {
      // Gather indices are computed in float (exact below 2^24).
      if (double(nb.width) * nb.height >= double(1 << 24)) simd = SimdLevel::kNone;
    }
    const int lanes = simd == SimdLevel::kAvx512 ? 16 : 8;
    prep.stride =
        simd != SimdLevel::kNone ? (input.width + lanes - 1) / lanes * lanes : input.width;
    if (simd != SimdLevel::kNone) {
      prep.ref_neg.assign(size_t(prep.stride) * input.height, 0.0f);
      for (int y = 0; y < input.height; ++y) {
        for (int x = 0; x < input.width; ++x) {
          prep.ref_neg[size_t(y) * prep.stride + x] = -input.reference[size_t(y) * input.width + x];
        }
      }
      for (const auto& nb : input.neighbours) {
        prep.taps.push_back(PackTaps(nb));
        const float* end = nb.image + size_t(nb.width) * nb.height;
        prep.holes.push_back(std::any_of(nb.image, end, [](float g) { return !(g == g); }));
      }
    }
  }
  const int64_t bands = (input.height + kBandRows - 1) / kBandRows;
  const auto run_bands = [&](int64_t b, int64_t e) {
    switch (simd) {
      case SimdLevel::kAvx512:
        (prewarp ? RunBandsPrewarpAvx512 : RunBandsAvx512)(input, prep, b, e, outputs);
        break;
      case SimdLevel::kAvx2:
        (prewarp ? RunBandsPrewarpAvx2 : RunBandsAvx2)(input, prep, b, e, outputs);
        break;
      case SimdLevel::kNone:
        (prewarp ? RunBandsPrewarpScalar : RunBandsScalar)(input, prep, b, e, outputs);
        break;
    }
  };
  if (input.tile_lo.empty()) {
    // Contiguous bands per thread: each hands the SSD rows it shares to the next.
    core::ParallelFor(0, bands, num_threads, run_bands);
  } else {
    // With per-tile levels bands cost what their tiles search (none in a background
    // band): one band at a time to the next free thread.
    const int threads = int(std::max<int64_t>(
        1, std::min<int64_t>(num_threads > 0 ? num_threads : core::HardwareThreads(), bands)));
    std::atomic<int64_t> next{0};
    core::ParallelFor(0, threads, threads, [&](int64_t, int64_t) {
      for (int64_t b = next++; b < bands; b = next++) run_bands(b, b + 1);
    });
  }
  for (auto& pw : prep.prewarped) {
    Pool<int16_t>::Give(&pw.q);
    Pool<int16_t>::Give(&pw.pair_ok);
  }
}

}  // namespace dome::stereo
