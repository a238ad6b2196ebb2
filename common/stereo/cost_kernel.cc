#include "stereo/cost_kernel.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/parallel_for.h"

namespace dome::stereo {
namespace {

constexpr int kBandRows = 32;
constexpr float kInf = std::numeric_limits<float>::infinity();

// Adds the squared differences of one reference row against neighbour `nb` warped by
// the homography of inverse depth w. Branch-free so that it vectorizes: the four
// bilinear taps are gathers with one 32-bit index vector over four base pointers
// (a 64-bit index would halve the gather width).
__attribute__((noinline)) void AccumulateRow(const KernelNeighbour& nb, float w, int y, int width,
                                             const float* __restrict ref, float outside_cost,
                                             float* __restrict ssd) {
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
  for (int x = 0; x < width; ++x) {
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

struct BandState {
  // Per pixel of the band (rows x width), one set per window size.
  std::vector<float> best, level, cm, cp, before, after, run, run_prev, prev;
  void Reset(size_t n) {
    best.assign(n, kInf);
    level.assign(n, -1.0f);
    cm.assign(n, kInf);
    cp.assign(n, kInf);
    before.assign(n, kInf);
    after.assign(n, kInf);
    run.assign(n, kInf);
    run_prev.assign(n, kInf);
    prev.assign(n, kInf);
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
__attribute__((noinline)) void UpdateRow(const float* __restrict cost, int n, float lvl,
                                         float* __restrict best, float* __restrict level,
                                         float* __restrict cm, float* __restrict cp,
                                         float* __restrict before, float* __restrict after,
                                         float* __restrict run, float* __restrict run_prev,
                                         float* __restrict prev) {
  // Plain selects on floats only, so that GCC vectorizes it (std::min through
  // references and mixed bool logic kept it scalar).
  for (int x = 0; x < n; ++x) {
    const float c = cost[x];
    const float b = best[x], lv = level[x], rn = run[x], rp = run_prev[x], pv = prev[x];
    const float bf = before[x], cmv = cm[x], cpv = cp[x], af = after[x];
    const bool nb = c < b;
    const bool adj = lvl == lv + 1.0f;
    const float af_min = c < af ? c : af;
    before[x] = nb ? rp : bf;
    cm[x] = nb ? pv : cmv;
    cp[x] = nb ? kInf : (adj ? c : cpv);
    after[x] = nb ? kInf : (adj ? af : af_min);
    best[x] = nb ? c : b;
    level[x] = nb ? lvl : lv;
    run_prev[x] = rn;
    run[x] = c < rn ? c : rn;
    prev[x] = c;
  }
}

void RunBands(const KernelInput& in, int64_t band_begin, int64_t band_end,
              std::vector<KernelOutput>* outputs) {
  const int width = in.width, height = in.height;
  const int nwin = static_cast<int>(in.half_windows.size());
  const int hmax = *std::max_element(in.half_windows.begin(), in.half_windows.end());
  std::vector<float> ssd(size_t(kBandRows + 2 * hmax) * width);
  std::vector<float> vsum(width), cost(width);
  std::vector<BandState> states(nwin);
  for (int64_t band = band_begin; band < band_end; ++band) {
    const int y0 = static_cast<int>(band) * kBandRows;
    const int y1 = std::min(height, y0 + kBandRows);
    const int s0 = std::max(0, y0 - hmax), s1 = std::min(height, y1 + hmax);
    for (auto& s : states) s.Reset(size_t(y1 - y0) * width);
    for (int l = 0; l < in.num_levels; ++l) {
      const float w = in.w_far + float(l) * in.w_step;
      std::fill(ssd.begin(), ssd.begin() + size_t(s1 - s0) * width, 0.0f);
      for (const auto& nb : in.neighbours) {
        for (int y = s0; y < s1; ++y) {
          AccumulateRow(nb, w, y, width, in.reference + size_t(y) * width, in.outside_cost,
                        ssd.data() + size_t(y - s0) * width);
        }
      }
      for (int k = 0; k < nwin; ++k) {
        const int h = in.half_windows[k];
        const int oy0 = std::max(y0, h), oy1 = std::min(y1, height - h);
        if (oy0 >= oy1 || width <= 2 * h) continue;
        BandState& st = states[k];
        // Vertical running sum over rows oy-h..oy+h.
        std::fill(vsum.begin(), vsum.end(), 0.0f);
        for (int yy = oy0 - h; yy <= oy0 + h; ++yy) {
          const float* row = ssd.data() + size_t(yy - s0) * width;
          for (int x = 0; x < width; ++x) vsum[x] += row[x];
        }
        for (int y = oy0; y < oy1; ++y) {
          if (y > oy0) {
            const float* add = ssd.data() + size_t(y + h - s0) * width;
            const float* sub = ssd.data() + size_t(y - h - 1 - s0) * width;
            for (int x = 0; x < width; ++x) vsum[x] += add[x] - sub[x];
          }
          const int n = width - 2 * h;
          float* c = cost.data();
          std::copy(vsum.begin(), vsum.begin() + n, c);
          for (int dx = 1; dx <= 2 * h; ++dx) {
            const float* v = vsum.data() + dx;
            for (int x = 0; x < n; ++x) c[x] += v[x];
          }
          const size_t o = size_t(y - y0) * width + h;
          UpdateRow(c, n, float(l), st.best.data() + o, st.level.data() + o, st.cm.data() + o,
                    st.cp.data() + o, st.before.data() + o, st.after.data() + o, st.run.data() + o,
                    st.run_prev.data() + o, st.prev.data() + o);
        }
      }
    }
    // Write the band's results.
    for (int k = 0; k < nwin; ++k) {
      const BandState& st = states[k];
      KernelOutput& out = (*outputs)[k];
      const int h = in.half_windows[k];
      for (int y = y0; y < y1; ++y) {
        for (int x = 0; x < width; ++x) {
          const size_t i = size_t(y - y0) * width + x;
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

}  // namespace

void RunCostKernel(const KernelInput& input, int num_threads, std::vector<KernelOutput>* outputs) {
  const int64_t bands = (input.height + kBandRows - 1) / kBandRows;
  core::ParallelFor(0, bands, num_threads,
                    [&](int64_t b, int64_t e) { RunBands(input, b, e, outputs); });
}

}  // namespace dome::stereo
