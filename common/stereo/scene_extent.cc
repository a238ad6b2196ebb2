#include "stereo/scene_extent.h"

#include <spdlog/spdlog.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <mutex>

#include "core/error.h"
#include "core/parallel_for.h"
#include "stereo/coarse_to_fine.h"
#include "stereo/take_stereo.h"

namespace dome::stereo {
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Focal length in pixels (the mean of x and y) of the ideal camera.
double FocalPx(const geometry::TsaiCamera& c) {
  return 0.5 * (c.focal_mm * c.sx / c.sensor.dpx_mm() + c.focal_mm / c.sensor.dpy_mm());
}

bool Inside(const geometry::TsaiCamera& c, const Eigen::Vector3d& x) {
  Eigen::Vector2d p;
  return c.Project(x, &p) && p.x() >= -0.5 && p.y() >= -0.5 && p.x() < c.width_px - 0.5 &&
         p.y() < c.height_px - 0.5;
}

}  // namespace

void SceneExtentOptions::Check() const {
  auto req = [](bool ok, const char* field, const std::string& what) {
    core::Require(ok, std::string("scene.") + field, what);
  };
  req(coarse_long_side_px >= 32, "coarse_long_side_px",
      "must be at least 32 px, got " + std::to_string(coarse_long_side_px));
  req(window_px >= 3 && window_px % 2 == 1, "window_px",
      "must be odd and at least 3, got " + std::to_string(window_px));
  req(std::isfinite(min_uniqueness) && min_uniqueness >= 0, "min_uniqueness",
      "must be >= 0, got " + std::to_string(min_uniqueness));
  req(std::isfinite(consistency_px) && consistency_px > 0, "consistency_px",
      "must be positive, got " + std::to_string(consistency_px));
  req(min_view_fraction >= 0 && min_view_fraction <= 1, "min_view_fraction",
      "must be in [0, 1], got " + std::to_string(min_view_fraction));
  req(std::isfinite(cell_px) && cell_px > 0, "cell_px",
      "must be positive, got " + std::to_string(cell_px));
  req(min_cell_points >= 1, "min_cell_points",
      "must be at least 1, got " + std::to_string(min_cell_points));
  req(min_piece_fraction >= 0 && min_piece_fraction <= 1, "min_piece_fraction",
      "must be in [0, 1], got " + std::to_string(min_piece_fraction));
  req(std::isfinite(margin_fraction) && margin_fraction >= 0, "margin_fraction",
      "must be >= 0, got " + std::to_string(margin_fraction));
  req(max_instants >= 1, "max_instants", "must be at least 1, got " + std::to_string(max_instants));
  req(min_points >= 1, "min_points", "must be at least 1, got " + std::to_string(min_points));
}

double PixelFootprintMm(const geometry::Rig& rig, const Eigen::Vector3d& point_mm) {
  std::vector<double> f;
  for (const auto& rc : rig.cameras) {
    const double z = rc.model.WorldToCamera(point_mm).z();
    if (z > 0) f.push_back(z / FocalPx(rc.model));
  }
  core::Require(!f.empty(), "rig", "no camera has the scene in front of it");
  return Median(f);
}

SceneExtent EstimateSceneExtent(const take::Take& take, const std::vector<std::string>& instants,
                                const StereoOptions& greys, const ClusterOptions& cluster,
                                const SceneExtentOptions& options,
                                const std::map<std::string, cv::Mat>& decoded) {
  options.Check();
  const auto& cams = take.rig.cameras;
  core::Require(cams.size() >= 2, "rig.json", "needs at least two cameras to find the scene");
  core::Require(!instants.empty(), "instants", "none to look at");
  SceneExtent e;

  // 1. The view centre: sum (I - a a^T) (c - C_i) = 0 over the axes (C_i, a_i).
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const auto& rc : cams) {
    const Eigen::Vector3d axis = rc.model.rotation.row(2).transpose();
    const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - axis * axis.transpose();
    a += p;
    b += p * rc.model.CentreWorld();
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(a);
  core::Require(svd.singularValues()(2) > 1e-3 * svd.singularValues()(0), "rig.json",
                "the cameras' optical axes do not converge on a region (parallel cameras): "
                "give the volume (dome run --box)");
  e.view_centre_mm = a.ldlt().solve(b);
  std::vector<double> radii, distances;
  for (const auto& rc : cams) {
    const geometry::TsaiCamera& c = rc.model;
    const double z = c.WorldToCamera(e.view_centre_mm).z();
    Eigen::Vector2d p;
    if (!(z > 0) || !c.Project(e.view_centre_mm, &p)) continue;
    const double edge =
        std::min({p.x() + 0.5, c.width_px - 0.5 - p.x(), p.y() + 0.5, c.height_px - 0.5 - p.y()});
    radii.push_back(std::max(0.0, edge) * z / FocalPx(c));
    distances.push_back((c.CentreWorld() - e.view_centre_mm).norm());
  }
  core::Require(radii.size() * 2 > cams.size(), "rig.json",
                "the cameras' axes meet behind most cameras: give the volume (dome run --box)");
  e.view_radius_mm = Median(radii);
  e.median_distance_mm = Median(distances);
  core::Require(e.view_radius_mm > 0, "rig.json",
                "the point the cameras' axes converge on is outside most images: give the "
                "volume (dome run --box)");

  // 2. Coarse stereo per (instant, camera).
  int long_side = 0;
  for (const auto& rc : cams)
    long_side = std::max({long_side, rc.model.width_px, rc.model.height_px});
  e.reduction =
      std::max(1, (long_side + options.coarse_long_side_px - 1) / options.coarse_long_side_px);
  const int f = e.reduction;
  const int n = int(instants.size()), k = std::min(n, options.max_instants);
  for (int i = 0; i < k; ++i)
    e.instants.push_back(instants[k == 1 ? n / 2 : i * (n - 1) / (k - 1)]);

  StereoOptions coarse = greys;
  coarse.normalize_contrast = false;  // applied by GreyImage below
  coarse.sqrt_greys = false;
  coarse.window_sizes_px = {options.window_px};
  coarse.min_uniqueness = options.min_uniqueness;
  coarse.num_levels = 0;
  coarse.level_step_px = 1.0;
  coarse.speckle = {};
  coarse.num_threads = 1;  // parallel over cameras instead
  const double reach = 2.0 * e.view_radius_mm;

  struct Job {
    int instant, camera;
  };
  std::vector<Job> jobs;
  for (int t = 0; t < k; ++t)
    for (int c = 0; c < int(cams.size()); ++c) jobs.push_back({t, c});
  std::vector<cv::Mat> depth(jobs.size());  // coarse ideal-camera depth, mm (0: none)
  std::vector<std::vector<int>> clusters(cams.size());
  std::vector<geometry::TsaiCamera> reduced(cams.size());
  for (size_t c = 0; c < cams.size(); ++c) {
    clusters[c] = SelectCluster(take.rig, cams[c].model.id, cluster);
    // Range images of multi_baseline.h are in the ideal camera.
    reduced[c] = ReducedCamera(cams[c].model, f).Ideal();
  }
  // Every camera's reduced grey image, made once: each is the reference of its own job
  // and a neighbour in others' (decoding and undistorting a frame is most of the cost).
  std::vector<cv::Mat> reduced_greys(jobs.size());
  core::ParallelFor(0, int64_t(jobs.size()), options.num_threads, [&](int64_t j0, int64_t j1) {
    for (int64_t j = j0; j < j1; ++j) {
      const auto& model = cams[jobs[j].camera].model;
      const std::string path = take.FramePath(e.instants[jobs[j].instant], model.id).string();
      const auto given = decoded.find(path);
      StereoView v{model, given != decoded.end() ? given->second : ReadFrame(path)};
      const cv::Mat g = GreyImage(v, greys, /*undistort=*/true, "camera '" + model.id + "'");
      reduced_greys[j] = f > 1 ? ReduceGrey(g, f) : g;
    }
  });
  auto grey_of = [&](int t, int c) { return reduced_greys[size_t(t) * cams.size() + c]; };
  core::ParallelFor(0, int64_t(jobs.size()), options.num_threads, [&](int64_t j0, int64_t j1) {
    for (int64_t j = j0; j < j1; ++j) {
      const int t = jobs[j].instant, c = jobs[j].camera;
      StereoInput in;
      in.reference = {reduced[c], grey_of(t, c)};
      for (int nb : clusters[c]) in.neighbours.push_back({reduced[nb], grey_of(t, nb)});
      StereoOptions o = coarse;
      const double z = cams[c].model.WorldToCamera(e.view_centre_mm).z();
      o.z_max_mm = z + reach;
      o.z_min_mm = std::max(0.05 * z, z - reach);
      if (!(o.z_min_mm < o.z_max_mm)) continue;
      depth[j] = ComputeDepth(in, o).range_images[0].depth_mm;
    }
  });

  // 3. Points that another camera of the cluster confirms and most cameras see.
  std::vector<Eigen::Vector3d> points;
  std::mutex mutex;
  const size_t need_views = size_t(std::ceil(options.min_view_fraction * double(cams.size())));
  core::ParallelFor(0, int64_t(jobs.size()), options.num_threads, [&](int64_t j0, int64_t j1) {
    std::vector<Eigen::Vector3d> mine;
    for (int64_t j = j0; j < j1; ++j) {
      if (depth[j].empty()) continue;
      const int t = jobs[j].instant, c = jobs[j].camera;
      const geometry::TsaiCamera& rc = reduced[c];
      const cv::Mat& d = depth[j];
      for (int y = 0; y < d.rows; ++y) {
        for (int x = 0; x < d.cols; ++x) {
          const float z = d.at<float>(y, x);
          if (!(z > 0)) continue;
          const Eigen::Vector3d w = rc.BackProjectAtDepth(Eigen::Vector2d(x, y), z);
          bool agreed = false;
          for (int nb : clusters[c]) {
            const cv::Mat& dn = depth[size_t(t) * cams.size() + nb];
            if (dn.empty()) continue;
            Eigen::Vector2d p;
            if (!reduced[nb].Project(w, &p)) continue;
            const int px = int(std::lround(p.x())), py = int(std::lround(p.y()));
            if (px < 0 || py < 0 || px >= dn.cols || py >= dn.rows) continue;
            const float zn = dn.at<float>(py, px);
            const double zw = reduced[nb].WorldToCamera(w).z();
            if (zn > 0 && std::abs(zn - zw) <= options.consistency_px * zw / FocalPx(reduced[nb])) {
              agreed = true;
              break;
            }
          }
          if (!agreed) continue;
          size_t views = 0;
          for (const auto& other : reduced) views += Inside(other, w);
          if (views >= need_views) mine.push_back(w);
        }
      }
    }
    std::lock_guard<std::mutex> lock(mutex);
    points.insert(points.end(), mine.begin(), mine.end());
  });
  e.points = int64_t(points.size());

  // 4. The box: the points binned in cells of cell_px coarse footprints at the view
  //    centre; cells with at least min_cell_points are occupied; 26-connected pieces of
  //    occupied cells are kept when they hold at least min_piece_fraction of the largest
  //    piece's points (the scene's objects, not stray matches); the kept cells' bounds.
  Eigen::Vector3d lo, hi;
  std::vector<double> fp;
  for (const auto& rc : reduced) {
    const double z = rc.WorldToCamera(e.view_centre_mm).z();
    if (z > 0) fp.push_back(z / FocalPx(rc));
  }
  const double cell = options.cell_px * Median(fp);
  std::map<std::array<int, 3>, int> count;
  for (const auto& p : points) {
    const Eigen::Vector3d q = (p - e.view_centre_mm) / cell;
    ++count[{int(std::floor(q.x())), int(std::floor(q.y())), int(std::floor(q.z()))}];
  }
  std::map<std::array<int, 3>, int> piece;  // occupied cell -> piece index
  std::vector<int64_t> piece_points;
  for (const auto& [c, n] : count) {
    if (n < options.min_cell_points || piece.count(c)) continue;
    const int id = int(piece_points.size());
    piece_points.push_back(0);
    std::vector<std::array<int, 3>> stack = {c};
    piece[c] = id;
    while (!stack.empty()) {
      const auto u = stack.back();
      stack.pop_back();
      piece_points[id] += count[u];
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const std::array<int, 3> v = {u[0] + dx, u[1] + dy, u[2] + dz};
            const auto it = count.find(v);
            if (it == count.end() || it->second < options.min_cell_points || piece.count(v))
              continue;
            piece[v] = id;
            stack.push_back(v);
          }
    }
  }
  const int64_t largest =
      piece_points.empty() ? 0 : *std::max_element(piece_points.begin(), piece_points.end());
  lo = Eigen::Vector3d::Constant(INFINITY);
  hi = -lo;
  e.points = 0;
  auto kept = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d q = (p - e.view_centre_mm) / cell;
    const auto it =
        piece.find({int(std::floor(q.x())), int(std::floor(q.y())), int(std::floor(q.z()))});
    return it != piece.end() &&
           double(piece_points[it->second]) >= options.min_piece_fraction * double(largest);
  };
  if (spdlog::should_log(spdlog::level::debug)) {
    std::vector<Eigen::Vector3d> plo(piece_points.size(), Eigen::Vector3d::Constant(INFINITY)),
        phi(piece_points.size(), Eigen::Vector3d::Constant(-INFINITY));
    for (const auto& [c, id] : piece) {
      const Eigen::Vector3d corner = e.view_centre_mm + cell * Eigen::Vector3d(c[0], c[1], c[2]);
      plo[id] = plo[id].cwiseMin(corner);
      phi[id] = phi[id].cwiseMax(corner + Eigen::Vector3d::Constant(cell));
    }
    for (size_t id = 0; id < piece_points.size(); ++id)
      if (piece_points[id] * 1000 >= largest)
        spdlog::debug("scene: piece {}: {} points, [{:.1f} {:.1f} {:.1f}] .. [{:.1f} {:.1f} {:.1f}]",
                      id, piece_points[id], plo[id].x(), plo[id].y(), plo[id].z(), phi[id].x(),
                      phi[id].y(), phi[id].z());
  }
  for (const auto& [c, id] : piece) {
    if (double(piece_points[id]) < options.min_piece_fraction * double(largest)) continue;
    const Eigen::Vector3d corner = e.view_centre_mm + cell * Eigen::Vector3d(c[0], c[1], c[2]);
    lo = lo.cwiseMin(corner);
    hi = hi.cwiseMax(corner + Eigen::Vector3d::Constant(cell));
    e.points += count.at(c);
  }
  if (e.points >= options.min_points) {
    e.from_stereo = true;
  } else {
    spdlog::warn(
        "scene: only {} coarse points agree between cameras; the volume is the sphere "
        "every camera sees",
        e.points);
    lo = e.view_centre_mm.array() - e.view_radius_mm;
    hi = e.view_centre_mm.array() + e.view_radius_mm;
  }
  // 5. Per camera depth ranges of the kept points.
  e.camera_depth_mm.assign(cams.size(), {0.0, 0.0});
  if (e.from_stereo) {
    std::vector<Eigen::Vector3d> scene;
    for (const auto& p : points)
      if (kept(p)) scene.push_back(p);
    core::ParallelFor(0, int64_t(cams.size()), options.num_threads, [&](int64_t c0, int64_t c1) {
      for (int64_t c = c0; c < c1; ++c) {
        std::vector<double> z;
        for (const auto& p : scene)
          if (Inside(reduced[c], p)) z.push_back(reduced[c].WorldToCamera(p).z());
        if (z.size() < 10) continue;
        const size_t q = z.size() / 500;
        std::nth_element(z.begin(), z.begin() + q, z.end());
        const double z0 = z[q];
        std::nth_element(z.begin() + q, z.end() - 1 - q, z.end());
        const double z1 = z[z.size() - 1 - q];
        const double widen = options.margin_fraction * (z1 - z0) + 2.0 * z0 / FocalPx(reduced[c]);
        e.camera_depth_mm[c] = {std::max(0.5 * z0, z0 - widen), z1 + widen};
      }
    });
  }
  const Eigen::Vector3d pad = options.margin_fraction * (hi - lo);
  e.min_mm = lo - pad;
  e.max_mm = hi + pad;
  return e;
}

}  // namespace dome::stereo
