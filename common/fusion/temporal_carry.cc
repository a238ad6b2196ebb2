#include "fusion/temporal_carry.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace dome::fusion {

void TemporalCarryOptions::Check() const {
  core::Require(std::isfinite(decay) && decay > 0.0 && decay <= 1.0, "temporal.fusion_decay",
                "expected a factor in (0, 1], got " + std::to_string(decay));
  core::Require(block_voxels >= 1, "temporal.fusion_block_voxels",
                "expected at least 1 voxel, got " + std::to_string(block_voxels));
  core::Require(changed_fraction > 0.0 && changed_fraction <= 1.0,
                "temporal.fusion_changed_fraction",
                "expected a fraction in (0, 1], got " + std::to_string(changed_fraction));
}

namespace {

// Changed tiles of one view as a summed-area table, (rows + 1) x (cols + 1).
struct TileSums {
  std::vector<int> sum;
  int cols = 0, rows = 0;
  int Count(int c0, int r0, int c1, int r1) const {  // tiles [c0, c1) x [r0, r1)
    const int w = cols + 1;
    return sum[size_t(r1) * w + c1] - sum[size_t(r0) * w + c1] - sum[size_t(r1) * w + c0] +
           sum[size_t(r0) * w + c0];
  }
};

TileSums Sums(const cv::Mat& changed) {
  TileSums t;
  t.cols = changed.cols;
  t.rows = changed.rows;
  t.sum.assign(size_t(t.rows + 1) * size_t(t.cols + 1), 0);
  for (int r = 0; r < t.rows; ++r) {
    int run = 0;
    for (int c = 0; c < t.cols; ++c) {
      run += changed.at<uint8_t>(r, c) != 0;
      t.sum[size_t(r + 1) * (t.cols + 1) + c + 1] = t.sum[size_t(r) * (t.cols + 1) + c + 1] + run;
    }
  }
  return t;
}

}  // namespace

void CarryStill(const VolumeGrid& grid, const Slab& previous, const std::vector<ChangeView>& views,
                const TemporalCarryOptions& options, const std::string& where, Slab* slab,
                TemporalCarryStats* stats) {
  options.Check();
  core::Require(previous.k0 == slab->k0 && previous.k1 == slab->k1 && previous.nx == slab->nx &&
                    previous.ny == slab->ny &&
                    previous.distance_mm.size() == slab->distance_mm.size() &&
                    previous.weight.size() == slab->weight.size(),
                where,
                "the previous instant's slab is planes " + std::to_string(previous.k0) + ".." +
                    std::to_string(previous.k1) + " of " + std::to_string(previous.nx) + "x" +
                    std::to_string(previous.ny) + ", this one's " + std::to_string(slab->k0) +
                    ".." + std::to_string(slab->k1) + " of " + std::to_string(slab->nx) + "x" +
                    std::to_string(slab->ny));
  std::vector<TileSums> sums;
  for (const ChangeView& v : views) {
    const int t = v.tile_px;
    core::Require(t >= 1 && v.changed_tiles.type() == CV_8UC1 &&
                      v.changed_tiles.cols == (v.camera.width_px + t - 1) / t &&
                      v.changed_tiles.rows == (v.camera.height_px + t - 1) / t,
                  where,
                  "camera '" + v.camera.id + "': its changed tiles do not cut its " +
                      std::to_string(v.camera.width_px) + "x" +
                      std::to_string(v.camera.height_px) + " image in tiles of " +
                      std::to_string(t) + " px");
    sums.push_back(Sums(v.changed_tiles));
  }
  const int b = options.block_voxels;
  const int nbx = (grid.nx + b - 1) / b, nby = (grid.ny + b - 1) / b;
  // Blocks are aligned to the whole grid (k / b), not to the slab, so a voxel's verdict
  // does not depend on how the volume is cut into slabs.
  const int bk0 = slab->k0 / b, bk1 = (slab->k1 + b - 1) / b;
  // The blocks' corners, projected once into each view: (nbx + 1) x (nby + 1) x planes.
  const int cx = nbx + 1, cy = nby + 1, cz = bk1 - bk0 + 1;
  struct Corner {
    float x, y;
    bool front;  // in front of the camera, projected
  };
  std::vector<std::vector<Corner>> corners(views.size());
  for (size_t v = 0; v < views.size(); ++v) {
    auto& c = corners[v];
    c.resize(size_t(cx) * cy * cz);
    for (int k = 0; k < cz; ++k)
      for (int j = 0; j < cy; ++j)
        for (int i = 0; i < cx; ++i) {
          // Corner (i b, j b, k b) of the voxel lattice (voxel corners, not centres),
          // clamped to the grid's far faces.
          const Eigen::Vector3d w =
              grid.origin_mm + grid.voxel_size_mm * Eigen::Vector3d(std::min(i * b, grid.nx),
                                                                    std::min(j * b, grid.ny),
                                                                    std::min((bk0 + k) * b, grid.nz));
          const Eigen::Vector3d cam = views[v].camera.WorldToCamera(w);
          Eigen::Vector2d p;
          const bool front = cam.z() > 0 && views[v].camera.ProjectCamera(cam, &p);
          c[(size_t(k) * cy + j) * cx + i] = {front ? float(p.x()) : 0.f,
                                              front ? float(p.y()) : 0.f, front};
        }
  }
  TemporalCarryStats st;
  const float decay = float(options.decay);
  for (int bk = bk0; bk < bk1; ++bk) {
    for (int bj = 0; bj < nby; ++bj) {
      for (int bi = 0; bi < nbx; ++bi) {
        ++st.blocks;
        const int i0 = bi * b, i1 = std::min(grid.nx, i0 + b);
        const int j0 = bj * b, j1 = std::min(grid.ny, j0 + b);
        const int k0 = std::max(slab->k0, bk * b), k1 = std::min(slab->k1, (bk + 1) * b);
        // Only blocks observed at both instants have anything to carry.
        bool any = false;
        for (int k = k0; k < k1 && !any; ++k)
          for (int j = j0; j < j1 && !any; ++j) {
            const size_t row = (size_t(k - slab->k0) * slab->ny + j) * slab->nx;
            const float* wp = previous.weight.data() + row;
            const float* w = slab->weight.data() + row;
            for (int i = i0; i < i1; ++i) any |= wp[i] > 0 && w[i] > 0;
          }
        if (!any) continue;
        int seen = 0, changed = 0;
        for (size_t v = 0; v < views.size(); ++v) {
          const ChangeView& view = views[v];
          float x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
          int front = 0;
          for (int c = 0; c < 8; ++c) {
            const Corner& q = corners[v][(size_t(bk - bk0 + (c >> 2 & 1)) * cy + bj + (c >> 1 & 1)) * cx +
                                         bi + (c & 1)];
            if (!q.front) continue;
            ++front;
            x0 = std::min(x0, q.x), x1 = std::max(x1, q.x);
            y0 = std::min(y0, q.y), y1 = std::max(y1, q.y);
          }
          if (front == 0) continue;  // behind this camera
          const int t = view.tile_px;
          int c0 = 0, r0 = 0, c1 = sums[v].cols, r1 = sums[v].rows;
          if (front == 8) {
            // The tiles the corners' rectangle meets.
            c0 = std::max(0, int(std::floor(x0 / t)));
            r0 = std::max(0, int(std::floor(y0 / t)));
            c1 = std::min(sums[v].cols, int(std::floor(x1 / t)) + 1);
            r1 = std::min(sums[v].rows, int(std::floor(y1 / t)) + 1);
            if (c0 >= c1 || r0 >= r1) continue;  // outside this image
          }
          // A block across the camera's plane may project anywhere: the whole image.
          ++seen;
          changed += sums[v].Count(c0, r0, c1, r1) > 0;
        }
        if (seen == 0 || changed >= options.changed_fraction * seen) continue;
        ++st.still_blocks;
        for (int k = k0; k < k1; ++k)
          for (int j = j0; j < j1; ++j) {
            const size_t row = (size_t(k - slab->k0) * slab->ny + j) * slab->nx;
            const float* dp = previous.distance_mm.data() + row;
            const float* wp = previous.weight.data() + row;
            float* d = slab->distance_mm.data() + row;
            float* w = slab->weight.data() + row;
            for (int i = i0; i < i1; ++i) {
              if (!(wp[i] > 0 && w[i] > 0)) continue;
              const float carried = decay * wp[i];
              const float total = w[i] + carried;
              d[i] = (w[i] * d[i] + carried * dp[i]) / total;
              w[i] = total;
              ++st.voxels_carried;
            }
          }
      }
    }
  }
  if (stats) *stats = st;
}

}  // namespace dome::fusion
