#include "silhouette/photo_hull.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <string>

#include "core/error.h"
#include "core/parallel_for.h"

namespace dome::silhouette {

void PhotoHullOptions::Check() const {
  auto positive = [](double v, const char* field) {
    core::Require(std::isfinite(v) && v > 0, std::string("PhotoHullOptions: ") + field,
                  "expected a positive value, got " + std::to_string(v));
  };
  positive(cell_mm, "cell_mm");
  positive(max_colour_distance, "max_colour_distance");
  positive(depth_tolerance_cells, "depth_tolerance_cells");
  core::Require(colour_box_px >= 1 && colour_box_px % 2 == 1, "PhotoHullOptions: colour_box_px",
                "expected an odd count >= 1, got " + std::to_string(colour_box_px));
  core::Require(visibility_px >= 1, "PhotoHullOptions: visibility_px",
                "expected >= 1, got " + std::to_string(visibility_px));
  core::Require(std::isfinite(stop_fraction) && stop_fraction >= 0 && stop_fraction < 1,
                "PhotoHullOptions: stop_fraction",
                "expected a fraction in [0, 1), got " + std::to_string(stop_fraction));
  core::Require(max_sweeps >= 1, "PhotoHullOptions: max_sweeps",
                "expected >= 1, got " + std::to_string(max_sweeps));
  core::Require(open_radius_cells >= 0, "PhotoHullOptions: open_radius_cells",
                "expected >= 0, got " + std::to_string(open_radius_cells));
}

namespace {

// Cell states.
constexpr uint8_t kOutside = 0;  // never in the hull
constexpr uint8_t kKept = 1;
constexpr uint8_t kCarved = 2;

// Where a cell's centre falls in one camera: its pixel, the z-buffers' pixel (zx, zy),
// its depth and the half side of its footprint in z-buffer pixels (a cell of edge e at
// depth z covers about e f / z image pixels).
struct Footprint {
  int x = 0, y = 0, zx = 0, zy = 0, r = 0;
  double z_mm = 0;
};

// `visit(value)` on every z-buffer pixel of the footprint (a width x height buffer,
// row-major), so that cells behind do not show through between the centres of those in
// front.
template <typename T, typename Visit>
void Splat(const Footprint& f, cv::Size size, std::vector<T>* buffer, Visit&& visit) {
  for (int yy = std::max(0, f.zy - f.r); yy <= std::min(size.height - 1, f.zy + f.r); ++yy) {
    T* row = buffer->data() + int64_t(yy) * size.width;
    for (int xx = std::max(0, f.zx - f.r); xx <= std::min(size.width - 1, f.zx + f.r); ++xx)
      visit(row[xx]);
  }
}

// The opening of the cells marked `kept` in `state` (an nx x ny x nz grid, x fastest)
// by a ball of `r` cells: eroded (a cell stays when its whole ball is kept; cells whose
// ball leaves the grid do not), then dilated. 1 = in the opening; a subset of the kept.
std::vector<uint8_t> OpenedCells(const std::vector<uint8_t>& state, uint8_t kept, int nx, int ny,
                                 int nz, int r, int threads) {
  const int64_t plane = int64_t(nx) * ny, cells = plane * nz;
  std::vector<int64_t> ball;  // index offsets of the ball's cells
  for (int dk = -r; dk <= r; ++dk)
    for (int dj = -r; dj <= r; ++dj)
      for (int di = -r; di <= r; ++di)
        if (di * di + dj * dj + dk * dk <= r * r) ball.push_back((dk * int64_t(ny) + dj) * nx + di);
  std::vector<uint8_t> eroded(size_t(cells), 0), opened(size_t(cells), 0);
  core::ParallelFor(r, nz - r, threads, [&](int64_t k0, int64_t k1) {
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = r; j < ny - r; ++j)
        for (int64_t i = r; i < nx - r; ++i) {
          const int64_t c = k * plane + j * nx + i;
          if (state[size_t(c)] != kept) continue;
          bool all = true;
          for (int64_t o : ball) all = all && state[size_t(c + o)] == kept;
          eroded[size_t(c)] = all;
        }
  });
  for (int64_t c = 0; c < cells; ++c)
    if (eroded[size_t(c)])
      for (int64_t o : ball) opened[size_t(c + o)] = 1;
  return opened;
}

// One surface cell as one camera sees it.
struct Sighting {
  int pixel = -1;    // index into the z-buffer; -1: not in front or outside the image
  float z_mm = 0;    // camera depth
  cv::Vec3f colour;  // box-filtered colour at the centre's pixel
};

}  // namespace

PhotoHull::PhotoHull(const VisualHull& hull, const std::vector<geometry::TsaiCamera>& cameras,
                     const std::vector<cv::Mat>& images, const Eigen::Vector3d& lo_mm,
                     const Eigen::Vector3d& hi_mm, const PhotoHullOptions& options) {
  options.Check();
  const size_t n_cams = cameras.size();
  core::Require(int(n_cams) == hull.num_cameras() && images.size() == n_cams, "photo hull",
                "expected one camera and one image per hull camera (" +
                    std::to_string(hull.num_cameras()) + "), got " + std::to_string(n_cams) +
                    " cameras and " + std::to_string(images.size()) + " images");
  for (size_t c = 0; c < n_cams; ++c) {
    const cv::Mat& im = images[c];
    core::Require(
        im.type() == CV_8UC3 && im.cols == cameras[c].width_px && im.rows == cameras[c].height_px,
        "photo hull: camera " + cameras[c].id,
        "expected a " + std::to_string(cameras[c].width_px) + "x" +
            std::to_string(cameras[c].height_px) + " colour image, got " + std::to_string(im.cols) +
            "x" + std::to_string(im.rows) + " with " + std::to_string(im.channels()) +
            " channel(s)");
  }
  const int threads = options.num_threads > 0 ? options.num_threads : core::HardwareThreads();
  cell_mm_ = options.cell_mm;
  origin_mm_ = lo_mm;
  const Eigen::Vector3d extent = (hi_mm - lo_mm) / cell_mm_;
  nx_ = std::max(1, int(std::ceil(extent.x())));
  ny_ = std::max(1, int(std::ceil(extent.y())));
  nz_ = std::max(1, int(std::ceil(extent.z())));
  const int64_t plane = int64_t(nx_) * ny_, cells = plane * nz_;
  auto centre = [&](int64_t cell) {
    const int64_t k = cell / plane, j = (cell % plane) / nx_, i = cell % nx_;
    return Eigen::Vector3d(origin_mm_ + (Eigen::Vector3d(double(i), double(j), double(k)) +
                                         Eigen::Vector3d::Constant(0.5)) *
                                            cell_mm_);
  };

  std::vector<uint8_t> state(size_t(cells), kOutside);
  // Only the verdict is needed: a cell's vote stops once enough cameras carve it
  // (enough_outside_mm 0), as most of the hull's box is outside it.
  core::ParallelFor(0, nz_, threads, [&](int64_t k0, int64_t k1) {
    for (int64_t c = k0 * plane; c < k1 * plane; ++c)
      if (hull.Sample(centre(c), 0.0, -1, 0.0).inside) state[size_t(c)] = kKept;
  });
  for (uint8_t s : state) stats_.hull_cells += s == kKept;

  // Box-filtered images, kept as float colours.
  std::vector<cv::Mat> colours(n_cams);
  core::ParallelFor(0, int64_t(n_cams), threads, [&](int64_t b, int64_t e) {
    for (int64_t c = b; c < e; ++c) {
      cv::Mat f;
      images[size_t(c)].convertTo(f, CV_32FC3);
      cv::blur(f, colours[size_t(c)], cv::Size(options.colour_box_px, options.colour_box_px));
    }
  });
  const int s = options.visibility_px;
  std::vector<cv::Size> zsize(n_cams);
  for (size_t c = 0; c < n_cams; ++c)
    zsize[c] = cv::Size((cameras[c].width_px + s - 1) / s, (cameras[c].height_px + s - 1) / s);
  // The footprint of `cell` in `camera`; false when it is behind it or outside its image.
  auto footprint = [&](const geometry::TsaiCamera& camera, int64_t cell, Footprint* f) {
    const Eigen::Vector3d pc = camera.WorldToCamera(centre(cell));
    Eigen::Vector2d px;
    if (!camera.ProjectCamera(pc, &px)) return false;
    const long x = std::lround(px.x()), y = std::lround(px.y());
    if (x < 0 || y < 0 || x >= camera.width_px || y >= camera.height_px) return false;
    f->x = int(x);
    f->y = int(y);
    f->zx = f->x / s;
    f->zy = f->y / s;
    f->z_mm = pc.z();
    f->r = int(0.5 * cell_mm_ * camera.K()(0, 0) / pc.z() / s);
    return true;
  };
  const double max2 = options.max_colour_distance * options.max_colour_distance;
  const float tolerance = float(options.depth_tolerance_cells * cell_mm_);

  auto kept = [&](int64_t i, int64_t j, int64_t k) {
    if (i < 0 || j < 0 || k < 0 || i >= nx_ || j >= ny_ || k >= nz_) return false;
    return state[size_t(k * plane + j * nx_ + i)] == kKept;
  };
  std::vector<int64_t> surface;
  std::vector<Sighting> seen;  // surface cell x camera
  std::vector<std::vector<float>> zbuffer(n_cams);
  std::vector<uint8_t> carve;
  for (int sweep = 0; sweep < options.max_sweeps; ++sweep) {
    surface.clear();
    for (int64_t c = 0; c < cells; ++c) {
      if (state[size_t(c)] != kKept) continue;
      const int64_t k = c / plane, j = (c % plane) / nx_, i = c % nx_;
      if (!kept(i - 1, j, k) || !kept(i + 1, j, k) || !kept(i, j - 1, k) || !kept(i, j + 1, k) ||
          !kept(i, j, k - 1) || !kept(i, j, k + 1)) {
        surface.push_back(c);
      }
    }
    if (surface.empty()) break;
    const int64_t n_surface = int64_t(surface.size());
    seen.assign(size_t(n_surface) * n_cams, Sighting{});
    // Per camera: where each surface cell projects, then the nearest over each z-buffer
    // pixel, the cell's footprint splatted (a cell of edge e at depth z covers about
    // e f / z image pixels) so that cells behind do not show through between the
    // centres of those in front.
    core::ParallelFor(0, int64_t(n_cams), threads, [&](int64_t b, int64_t e) {
      for (int64_t cam = b; cam < e; ++cam) {
        const geometry::TsaiCamera& camera = cameras[size_t(cam)];
        const cv::Size zs = zsize[size_t(cam)];
        std::vector<float>& zb = zbuffer[size_t(cam)];
        zb.assign(size_t(zs.area()), std::numeric_limits<float>::infinity());
        for (int64_t q = 0; q < n_surface; ++q) {
          Footprint f;
          if (!footprint(camera, surface[size_t(q)], &f)) continue;
          Sighting& sg = seen[size_t(q) * n_cams + size_t(cam)];
          sg.pixel = f.zy * zs.width + f.zx;
          sg.z_mm = float(f.z_mm);
          sg.colour = colours[size_t(cam)].at<cv::Vec3f>(f.y, f.x);
          Splat(f, zs, &zb, [&](float& v) { v = std::min(v, sg.z_mm); });
        }
      }
    });
    carve.assign(size_t(n_surface), 0);
    core::ParallelFor(0, n_surface, threads, [&](int64_t b, int64_t e) {
      std::vector<const cv::Vec3f*> visible;
      for (int64_t q = b; q < e; ++q) {
        visible.clear();
        for (size_t cam = 0; cam < n_cams; ++cam) {
          const Sighting& sg = seen[size_t(q) * n_cams + cam];
          if (sg.pixel >= 0 && sg.z_mm <= zbuffer[cam][size_t(sg.pixel)] + tolerance)
            visible.push_back(&sg.colour);
        }
        // Consistent when two of the cameras that see it agree: a third may see an
        // occluder the z-buffer of the surface cells misses (the hull's ghost in front
        // of it is carved only later, or a part the masks left out).
        bool agree = false;
        for (size_t a = 0; a < visible.size() && !agree; ++a) {
          for (size_t o = a + 1; o < visible.size() && !agree; ++o) {
            const cv::Vec3f d = *visible[a] - *visible[o];
            agree = double(d.dot(d)) <= max2;
          }
        }
        carve[size_t(q)] = visible.size() >= 2 && !agree;
      }
    });
    int64_t carved = 0;
    for (int64_t q = 0; q < n_surface; ++q) {
      if (!carve[size_t(q)]) continue;
      state[size_t(surface[size_t(q)])] = kCarved;
      ++carved;
    }
    stats_.carved_cells += carved;
    stats_.sweeps = sweep + 1;
    if (double(carved) < options.stop_fraction * double(n_surface)) break;
  }
  if (options.open_radius_cells > 0) {
    // The opening (PhotoHullOptions::open_radius_cells), then what it removed.
    const std::vector<uint8_t> opened =
        OpenedCells(state, kKept, nx_, ny_, nz_, options.open_radius_cells, threads);
    std::vector<int64_t> removed;
    for (int64_t c = 0; c < cells; ++c)
      if (state[size_t(c)] == kKept && !opened[size_t(c)]) removed.push_back(c);
    // Per camera, the z-buffer pixels the kept cells cover and the opened ones do not;
    // a removed cell whose centre falls on one is kept.
    std::vector<std::vector<uint8_t>> needed(n_cams, std::vector<uint8_t>(removed.size(), 0));
    core::ParallelFor(0, int64_t(n_cams), threads, [&](int64_t b, int64_t e) {
      for (int64_t cam = b; cam < e; ++cam) {
        const geometry::TsaiCamera& camera = cameras[size_t(cam)];
        const cv::Size zs = zsize[size_t(cam)];
        // 1: covered by a kept cell, 2: by an opened one too.
        std::vector<uint8_t> cover(size_t(zs.area()), 0);
        for (int64_t c = 0; c < cells; ++c) {
          Footprint f;
          if (state[size_t(c)] != kKept || !footprint(camera, c, &f)) continue;
          const uint8_t mark = opened[size_t(c)] ? 2 : 1;
          Splat(f, zs, &cover, [&](uint8_t& v) { v = std::max(v, mark); });
        }
        for (size_t q = 0; q < removed.size(); ++q) {
          Footprint f;
          if (footprint(camera, removed[q], &f))
            needed[size_t(cam)][q] = cover[size_t(f.zy * zs.width + f.zx)] == 1;
        }
      }
    });
    for (size_t q = 0; q < removed.size(); ++q) {
      bool need = false;
      for (size_t cam = 0; cam < n_cams; ++cam) need = need || needed[cam][q];
      if (need) {
        ++stats_.restored_cells;
        continue;
      }
      state[size_t(removed[q])] = kCarved;
      ++stats_.opened_cells;
    }
    stats_.carved_cells += stats_.opened_cells;
  }
  carved_.resize(size_t(cells));
  for (int64_t c = 0; c < cells; ++c) carved_[size_t(c)] = state[size_t(c)] == kCarved;
}

double PhotoHull::CarvedDistanceMm(const Eigen::Vector3d& world_mm) const {
  const double h = 0.5 * cell_mm_;
  if (stats_.carved_cells == 0) return -h;
  // Cell coordinates with cell centres at integers.
  const Eigen::Vector3d u = (world_mm - origin_mm_) / cell_mm_ - Eigen::Vector3d::Constant(0.5);
  const double fx = std::floor(u.x()), fy = std::floor(u.y()), fz = std::floor(u.z());
  if (!(fx >= -1 && fy >= -1 && fz >= -1 && fx < nx_ && fy < ny_ && fz < nz_)) return -h;
  const int i0 = int(fx), j0 = int(fy), k0 = int(fz);
  const double tx = u.x() - fx, ty = u.y() - fy, tz = u.z() - fz;
  double value = 0;
  for (int c = 0; c < 8; ++c) {
    const int i = i0 + (c & 1), j = j0 + ((c >> 1) & 1), k = k0 + ((c >> 2) & 1);
    const bool in = i >= 0 && j >= 0 && k >= 0 && i < nx_ && j < ny_ && k < nz_;
    const bool carved = in && carved_[size_t((int64_t(k) * ny_ + j) * nx_ + i)] != 0;
    const double w =
        ((c & 1) ? tx : 1 - tx) * (((c >> 1) & 1) ? ty : 1 - ty) * (((c >> 2) & 1) ? tz : 1 - tz);
    value += w * (carved ? h : -h);
  }
  return value;
}

}  // namespace dome::silhouette
