#include "calib/detect.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace dome::calib {

using Eigen::Vector2d;
using Eigen::Vector3d;

void DotDetectorOptions::Check() const {
  core::Require(background_radius_px >= 1, "DotDetectorOptions: background_radius_px",
                "must be >= 1 px");
  core::Require(min_contrast > 0, "DotDetectorOptions: min_contrast",
                "must be positive (grey levels)");
  core::Require(max_blob_area_px >= 1, "DotDetectorOptions: max_blob_area_px", "must be >= 1 px^2");
  core::Require(key_mass_ratio > 1, "DotDetectorOptions: key_mass_ratio", "must exceed 1");
  core::Require(match_tolerance > 0 && match_tolerance < 0.5, "DotDetectorOptions: match_tolerance",
                "must be in (0, 0.5) of the grid pitch");
  core::Require(min_grid_points >= 4, "DotDetectorOptions: min_grid_points", "must be >= 4");
}

void ChessboardOptions::Check() const {
  core::Require(inner_corners_x >= 2 && inner_corners_y >= 2, "ChessboardOptions: inner_corners",
                "need at least 2 x 2 inner corners");
  core::Require(subpix_window_px >= 3 && subpix_window_px % 2 == 1,
                "ChessboardOptions: subpix_window_px", "must be odd and >= 3");
}

std::vector<Blob> DetectBlobs(const cv::Mat& gray, const DotDetectorOptions& options) {
  DOME_CHECK(gray.type() == CV_8UC1, "DetectBlobs needs an 8-bit grey image");
  cv::Mat img, dark;
  gray.convertTo(img, CV_32F);
  const int r = options.background_radius_px;
  // Black top-hat: closing (max then min filter) fills dark features narrower than the
  // kernel but keeps shading steps (where two plates meet), so only dots stand out.
  cv::morphologyEx(img, dark, cv::MORPH_BLACKHAT,
                   cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * r + 1, 2 * r + 1)));
  cv::Mat mask = dark > options.min_contrast;
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  std::vector<Blob> blobs;
  for (int k = 1; k < count; ++k) {
    const int area = stats.at<int>(k, cv::CC_STAT_AREA);
    if (area > options.max_blob_area_px) continue;
    const int x0 = std::max(0, stats.at<int>(k, cv::CC_STAT_LEFT) - 1);
    const int y0 = std::max(0, stats.at<int>(k, cv::CC_STAT_TOP) - 1);
    const int x1 = std::min(
        gray.cols - 1, stats.at<int>(k, cv::CC_STAT_LEFT) + stats.at<int>(k, cv::CC_STAT_WIDTH));
    const int y1 = std::min(
        gray.rows - 1, stats.at<int>(k, cv::CC_STAT_TOP) + stats.at<int>(k, cv::CC_STAT_HEIGHT));
    // Touching the border: the dot may be cut and its centroid biased. Kept for
    // matching (it may be the key marker) but never output as a point.
    const bool cut = x0 == 0 || y0 == 0 || x1 == gray.cols - 1 || y1 == gray.rows - 1;
    // Support: the component and its 8-neighbours that belong to no other component
    // (the dot's anti-aliased rim), weighted by darkness.
    double sw = 0, sx = 0, sy = 0;
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const int l = labels.at<int>(y, x);
        bool in = l == k;
        if (!in && l == 0) {
          for (int dy = -1; dy <= 1 && !in; ++dy) {
            for (int dx = -1; dx <= 1 && !in; ++dx) {
              const int yy = y + dy, xx = x + dx;
              if (yy >= 0 && yy < gray.rows && xx >= 0 && xx < gray.cols &&
                  labels.at<int>(yy, xx) == k)
                in = true;
            }
          }
        }
        if (!in) continue;
        const double w = std::max(0.0f, dark.at<float>(y, x));
        sw += w;
        sx += w * x;
        sy += w * y;
      }
    }
    if (sw <= 0) continue;
    blobs.push_back({Vector2d(sx / sw, sy / sw), sw, area, cut});
  }
  return blobs;
}

namespace {

struct GridFit {
  std::vector<int> blob_of_cell;  // n * n, -1 = not found
  int matched = 0;
  double error = 0.0;  // summed distance to predictions, px (tie breaker)
};

// Homography grid (i, j) -> image from the matched cells (least squares).
bool FitHomography(const std::vector<Blob>& blobs, const GridFit& fit, int n, cv::Mat* h) {
  std::vector<cv::Point2f> src, dst;
  for (int c = 0; c < n * n; ++c) {
    if (fit.blob_of_cell[c] < 0) continue;
    src.emplace_back(static_cast<float>(c % n), static_cast<float>(c / n));
    const auto& p = blobs[fit.blob_of_cell[c]].centre;
    dst.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  }
  if (src.size() < 4) return false;
  *h = cv::findHomography(src, dst, 0);
  return !h->empty();
}

Vector2d ApplyH(const cv::Mat& h, double i, double j) {
  const double x = h.at<double>(0, 0) * i + h.at<double>(0, 1) * j + h.at<double>(0, 2);
  const double y = h.at<double>(1, 0) * i + h.at<double>(1, 1) * j + h.at<double>(1, 2);
  const double w = h.at<double>(2, 0) * i + h.at<double>(2, 1) * j + h.at<double>(2, 2);
  return Vector2d(x / w, y / w);
}

// Nearest unused blob within `radius` of p whose mass is within a factor 3 of
// `mass` (a neighbouring dot's; 0 = any): dots of one grid change size smoothly.
int Nearest(const std::vector<Blob>& blobs, const Vector2d& p, double radius,
            const std::vector<char>& used, double* distance, double mass = 0.0) {
  int best = -1;
  double best_d = radius;
  for (size_t b = 0; b < blobs.size(); ++b) {
    if (used[b]) continue;
    if (mass > 0 && (blobs[b].mass > 3.0 * mass || blobs[b].mass < mass / 3.0)) continue;
    const double d = (blobs[b].centre - p).norm();
    if (d < best_d) {
      best_d = d;
      best = static_cast<int>(b);
    }
  }
  if (distance) *distance = best_d;
  return best;
}

// Grows the grid from seeds at cells (0,0), (1,0), (0,1), (1,1).
GridFit Grow(const std::vector<Blob>& blobs, int n, const int seed[4], double tolerance) {
  GridFit fit;
  fit.blob_of_cell.assign(n * n, -1);
  std::vector<char> used(blobs.size(), 0);
  const int cells[4] = {0, 1, n, n + 1};
  for (int s = 0; s < 4; ++s) {
    fit.blob_of_cell[cells[s]] = seed[s];
    used[seed[s]] = 1;
  }
  fit.matched = 4;
  auto pos = [&](int i, int j) -> const Vector2d* {
    if (i < 0 || j < 0 || i >= n || j >= n) return nullptr;
    const int b = fit.blob_of_cell[n * j + i];
    return b < 0 ? nullptr : &blobs[b].centre;
  };
  bool changed = true;
  while (changed) {
    changed = false;
    cv::Mat h;
    const bool have_h = FitHomography(blobs, fit, n, &h);
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        if (fit.blob_of_cell[n * j + i] >= 0) continue;
        Vector2d sum = Vector2d::Zero();
        double pitch = 0;
        int predictions = 0;
        const int dirs[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
        for (const auto& d : dirs) {
          const Vector2d* a = pos(i - d[0], j - d[1]);
          const Vector2d* b = pos(i - 2 * d[0], j - 2 * d[1]);
          const Vector2d* c = pos(i - 3 * d[0], j - 3 * d[1]);
          // (with fewer dots in the row the homography below, exact under perspective,
          // predicts better than a linear extrapolation)
          if (a && b && c) {
            // Three dots of a row: extrapolate projectively (the cross ratio of four
            // equally spaced grid points is 4/3), exact under perspective.
            const Vector2d u = (*a - *c).normalized();
            const double s0 = 0, s1 = (*b - *c).dot(u), s2 = (*a - *c).dot(u);
            const double big_a = s2 - s0, big_b = s2 - s1;
            const double den = 3 * big_a - 4 * big_b;
            if (std::abs(den) > 1e-9 * std::abs(big_a)) {
              const double s3 = (3 * big_a * s1 - 4 * big_b * s0) / den;
              sum += *c + s3 * u;
              pitch += (*a - *b).norm();
              ++predictions;
              continue;
            }
          }
        }
        bool adjacent = false;
        double neighbour_mass = 0.0;
        for (const auto& d : dirs) {
          const int ii = i - d[0], jj = j - d[1];
          if (pos(ii, jj) != nullptr) {
            adjacent = true;
            neighbour_mass = blobs[fit.blob_of_cell[n * jj + ii]].mass;
          }
        }
        if (predictions == 0) {
          if (!adjacent || !have_h) continue;
          sum = ApplyH(h, i, j);
          pitch = std::min((ApplyH(h, i + 1, j) - sum).norm(), (ApplyH(h, i, j + 1) - sum).norm());
          predictions = 1;
        } else {
          sum /= predictions;
          pitch /= predictions;
        }
        double distance = 0;
        const int b = Nearest(blobs, sum, tolerance * pitch, used, &distance, neighbour_mass);
        if (b < 0) continue;
        fit.blob_of_cell[n * j + i] = b;
        used[b] = 1;
        ++fit.matched;
        fit.error += distance;
        changed = true;
      }
    }
  }
  return fit;
}

// The key marker is the grid corner heaviest relative to the dots around it, each
// dot's mass divided by the area its grid cell covers in the image (the Jacobian
// determinant of the grid's homography there): perspective makes near dots heavier and
// far dots lighter, and at grazing views a plain comparison with the neighbours (or an
// extrapolation along a row) can pick a near corner or miss a far key. Relabels the
// grid by quarter turns (which keep its handedness) so that the key is at (0, 0);
// returns the key's ratio.
// When no corner stands out but the grid is complete save one corner that lies well
// inside the image, that corner is taken as the key: a key marker that merged with its
// surroundings (steep views shrink the white pad around it) is the likely reason.
double PutKeyAtOrigin(const std::vector<Blob>& blobs, int n, const cv::Size& image,
                      double key_ratio, GridFit* fit) {
  cv::Mat grid_h;
  const bool have_h = FitHomography(blobs, *fit, n, &grid_h);
  // Mass per unit of imaged cell area, 0 where unknown.
  auto density = [&](int i, int j) {
    const int b = fit->blob_of_cell[n * j + i];
    if (b < 0 || blobs[b].cut) return 0.0;
    if (!have_h) return blobs[b].mass;
    const Vector2d p = ApplyH(grid_h, i, j);
    const Vector2d du = ApplyH(grid_h, i + 0.5, j) - ApplyH(grid_h, i - 0.5, j);
    const Vector2d dv = ApplyH(grid_h, i, j + 0.5) - ApplyH(grid_h, i, j - 0.5);
    const double area = std::abs(du.x() * dv.y() - du.y() * dv.x());
    return p.allFinite() && area > 1e-9 ? blobs[b].mass / area : 0.0;
  };
  const int corner[4][2] = {{0, 0}, {n - 1, 0}, {n - 1, n - 1}, {0, n - 1}};
  double best_ratio = 0;
  int best = 0;
  for (int c = 0; c < 4; ++c) {
    const int ci = corner[c][0], cj = corner[c][1];
    const double m = density(ci, cj);
    if (m <= 0) continue;
    // the dots within two cells of the corner: the same size and contrast as the key
    std::vector<double> around;
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        if ((i == ci && j == cj) || std::abs(i - ci) > 2 || std::abs(j - cj) > 2) continue;
        const double d = density(i, j);
        if (d > 0) around.push_back(d);
      }
    }
    if (around.size() < 3) continue;
    std::nth_element(around.begin(), around.begin() + around.size() / 2, around.end());
    const double ratio = m / around[around.size() / 2];
    if (ratio > best_ratio) {
      best_ratio = ratio;
      best = c;
    }
  }
  if (best_ratio < key_ratio && fit->matched >= n * n - 2) {
    int missing = -1, missing_count = 0;
    for (int c = 0; c < 4; ++c) {
      const int b = fit->blob_of_cell[n * corner[c][1] + corner[c][0]];
      if (b < 0 || blobs[b].cut) {  // missing, or cut by the border (its mass unknown)
        missing = c;
        ++missing_count;
      }
    }
    cv::Mat h;
    if (missing_count == 1 && FitHomography(blobs, *fit, n, &h)) {
      const Vector2d p = ApplyH(h, corner[missing][0], corner[missing][1]);
      const int b = fit->blob_of_cell[n * corner[missing][1] + corner[missing][0]];
      if ((b >= 0 && blobs[b].cut) ||
          (p.x() > 3 && p.y() > 3 && p.x() < image.width - 4 && p.y() < image.height - 4)) {
        best = missing;
        best_ratio = key_ratio;
      }
    }
  }
  // quarter turn (i, j) -> (n-1-j, i) maps corner c to corner c+1; apply 4-best times
  for (int turn = 0; turn < (4 - best) % 4; ++turn) {
    std::vector<int> turned(n * n, -1);
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) turned[n * i + (n - 1 - j)] = fit->blob_of_cell[n * j + i];
    }
    fit->blob_of_cell = turned;
  }
  return best_ratio;
}

// Best grid grown from key blob `key`.
GridFit GrowFromKey(const std::vector<Blob>& blobs, int n, int key, double tolerance) {
  const Vector2d k = blobs[key].centre;
  std::vector<int> order(blobs.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return (blobs[a].centre - k).squaredNorm() < (blobs[b].centre - k).squaredNorm();
  });
  const int near = std::min<int>(21, static_cast<int>(order.size()));
  const double key_mass = blobs[key].mass;
  GridFit best;
  best.matched = 0;
  for (int ai = 1; ai < near; ++ai) {
    for (int bi = 1; bi < near; ++bi) {
      if (ai == bi) continue;
      const int a = order[ai], b = order[bi];
      const Vector2d va = blobs[a].centre - k, vb = blobs[b].centre - k;
      const double cross = va.x() * vb.y() - va.y() * vb.x();
      const double la = va.norm(), lb = vb.norm();
      // clockwise in image coordinates: the face seen from its front (see detect.h)
      if (!(cross < 0) || std::abs(cross) < 0.3 * la * lb) continue;
      if (la > 2.5 * lb || lb > 2.5 * la) continue;
      if (blobs[a].mass < 0.1 * key_mass || blobs[a].mass > 2.0 * key_mass ||
          blobs[b].mass < 0.1 * key_mass || blobs[b].mass > 2.0 * key_mass) {
        continue;
      }
      std::vector<char> used(blobs.size(), 0);
      used[key] = used[a] = used[b] = 1;
      // (1, 1) by the parallelogram rule, which perspective bends: a wider tolerance
      const int c = Nearest(blobs, k + va + vb, 2 * tolerance * std::min(la, lb), used, nullptr,
                            blobs[a].mass);
      if (c < 0) continue;
      const int seed[4] = {key, a, b, c};
      GridFit fit = Grow(blobs, n, seed, tolerance);
      if (fit.matched > best.matched || (fit.matched == best.matched && fit.error < best.error)) {
        best = std::move(fit);
        if (best.matched == n * n) return best;  // complete: no hypothesis can do better
      }
    }
  }
  return best;
}

// The best 3x4 projective fit (normalised DLT) of target -> image points.
struct DltFit {
  double rms = std::numeric_limits<double>::infinity();  // px
  Eigen::Matrix<double, 12, 1> p;
  Vector3d wc;
  Vector2d ic;
  double ws = 1, is = 1;
  Vector2d Project(const Vector3d& world) const {
    const Eigen::Vector4d x((world - wc).x() * ws, (world - wc).y() * ws, (world - wc).z() * ws, 1);
    const double w = p.segment<4>(8).dot(x);
    return Vector2d(p.segment<4>(0).dot(x) / w, p.segment<4>(4).dot(x) / w) / is + ic;
  }
};

DltFit Dlt(const std::vector<Vector3d>& world, const std::vector<Vector2d>& image) {
  DltFit fit;
  const int m = static_cast<int>(world.size());
  if (m < 6) return fit;
  fit.wc = Vector3d::Zero();
  fit.ic = Vector2d::Zero();
  for (int i = 0; i < m; ++i) {
    fit.wc += world[i];
    fit.ic += image[i];
  }
  fit.wc /= m;
  fit.ic /= m;
  double ws = 0, is = 0;
  for (int i = 0; i < m; ++i) {
    ws += (world[i] - fit.wc).norm();
    is += (image[i] - fit.ic).norm();
  }
  fit.ws = ws > 0 ? m / ws : 1;
  fit.is = is > 0 ? m / is : 1;
  Eigen::MatrixXd a(2 * m, 12);
  for (int i = 0; i < m; ++i) {
    const Vector3d w = (world[i] - fit.wc) * fit.ws;
    const Eigen::Vector4d x(w.x(), w.y(), w.z(), 1);
    const Vector2d u = (image[i] - fit.ic) * fit.is;
    a.row(2 * i) << x.transpose(), Eigen::RowVector4d::Zero(), -u.x() * x.transpose();
    a.row(2 * i + 1) << Eigen::RowVector4d::Zero(), x.transpose(), -u.y() * x.transpose();
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  fit.p = svd.matrixV().col(11);
  double sum = 0;
  for (int i = 0; i < m; ++i) sum += (fit.Project(world[i]) - image[i]).squaredNorm();
  fit.rms = std::sqrt(sum / m);
  return fit;
}

}  // namespace

std::string DotDetection::BriefReport() const {
  return fmt::format(
      "{} dots identified ({} blobs, {} grids); {} target points not found; {} "
      "claimed twice",
      points.size(), blobs, grids_found, missing_ids.size(), conflicting_ids.size());
}

DotDetection DetectDotTarget(const cv::Mat& gray, const Target& target, const GridLayout& layout,
                             const DotDetectorOptions& options, const std::string& where) {
  options.Check();
  core::Require(!gray.empty() && gray.type() == CV_8UC1, where, "expected an 8-bit grey image");
  DotDetection out;
  const std::vector<Blob> blobs = DetectBlobs(gray, options);
  out.blobs = static_cast<int>(blobs.size());
  const int grids = static_cast<int>(layout.grids.size());
  core::Require(!layout.grids.empty(), where, "the target has no grids");
  const int n = layout.grids[0].n;
  core::Require(static_cast<int>(blobs.size()) >= 4, where,
                fmt::format("only {} dark blobs found; expected the target's dots", blobs.size()));

  // Key candidates: blobs heavier than the median of their 6 nearest look-alikes
  // (blobs at least half as dark on average: dots, not floor texture). The candidate
  // bound is loose; the grid grown from a candidate decides (PutKeyAtOrigin).
  std::vector<std::pair<double, int>> keys;
  auto darkness = [&](int b) { return blobs[b].mass / std::max(1, blobs[b].area_px); };
  for (size_t b = 0; b < blobs.size(); ++b) {
    std::vector<std::pair<double, int>> near;
    for (size_t o = 0; o < blobs.size(); ++o) {
      if (o == b || darkness(static_cast<int>(o)) < 0.5 * darkness(static_cast<int>(b))) continue;
      near.emplace_back((blobs[o].centre - blobs[b].centre).squaredNorm(), static_cast<int>(o));
    }
    if (near.empty()) continue;
    const size_t k = std::min<size_t>(6, near.size());
    std::partial_sort(near.begin(), near.begin() + k, near.end());
    std::vector<double> masses;
    for (size_t i = 0; i < k; ++i) masses.push_back(blobs[near[i].second].mass);
    std::nth_element(masses.begin(), masses.begin() + masses.size() / 2, masses.end());
    const double ratio = blobs[b].mass / std::max(1e-9, masses[masses.size() / 2]);
    if (ratio >= 1.0 + 0.5 * (options.key_mass_ratio - 1.0))
      keys.emplace_back(darkness(static_cast<int>(b)), static_cast<int>(b));
  }
  core::Require(!keys.empty(), where, "no key marker (a dot larger than its neighbours) found");
  std::sort(keys.rbegin(), keys.rend());  // darkest first: printed dots, not texture
  // (plain marks, calib/target.h, are dots too: near ones stand out like keys)
  keys.resize(std::min<size_t>(keys.size(), 12 * grids + 24 + layout.plain_ids.size()));

  std::vector<GridFit> fits;
  for (const auto& [darkness_level, key] : keys) {
    GridFit fit = GrowFromKey(blobs, n, key, options.match_tolerance);
    const double corner_ratio =
        fit.matched > 0 ? PutKeyAtOrigin(blobs, n, gray.size(), options.key_mass_ratio, &fit) : 0.0;
    if (fit.matched > 0 && corner_ratio < options.key_mass_ratio) continue;
    fits.push_back(std::move(fit));
  }
  std::vector<int> order(fits.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return fits[a].matched > fits[b].matched; });
  std::vector<GridFit> found;
  std::vector<int> claims(blobs.size(), 0);
  for (int f : order) {
    if (static_cast<int>(found.size()) == grids) break;
    const GridFit& fit = fits[f];
    if (fit.matched < options.min_grid_points) continue;
    int overlap = 0;
    for (int b : fit.blob_of_cell) overlap += b >= 0 && claims[b] > 0;
    if ((fit.blob_of_cell[0] >= 0 && claims[fit.blob_of_cell[0]] > 0) || overlap > 2) continue;
    for (int b : fit.blob_of_cell) {
      if (b >= 0) ++claims[b];
    }
    found.push_back(fit);
  }
  out.grids_found = static_cast<int>(found.size());
  core::Require(!found.empty(), where,
                fmt::format("no grid of {} x {} dots found around any of {} key-marker candidates",
                            n, n, keys.size()));

  // Which found grid is which target grid: the assignment with the best projective fit.
  std::vector<int> assign(found.size());
  {
    std::vector<int> perm(grids);
    std::iota(perm.begin(), perm.end(), 0);
    // The fits of every assignment; a symmetric target (the synthetic object is
    // unchanged by a 120 deg turn about its diagonal) fits several equally well: among
    // those, take the one that shows the target's +z upwards in the image (the object
    // stands upright). The intrinsics do not depend on the choice.
    struct Candidate {
      std::vector<int> perm;
      double rms, up;
    };
    std::vector<Candidate> candidates;
    do {
      std::vector<Vector3d> world;
      std::vector<Vector2d> image;
      for (size_t g = 0; g < found.size(); ++g) {
        const Grid& grid = layout.grids[perm[g]];
        for (int c = 0; c < n * n; ++c) {
          const int b = found[g].blob_of_cell[c];
          if (b < 0 || claims[b] > 1) continue;
          world.push_back(target.points[target.Find(grid.ids[c])].position_mm);
          image.push_back(blobs[b].centre);
        }
      }
      if (grids == 1) {
        candidates.push_back({perm, 0.0, 0.0});
        continue;
      }
      const DltFit fit = Dlt(world, image);
      Vector3d centre = Vector3d::Zero();
      for (const auto& w : world) centre += w;
      centre /= std::max<size_t>(1, world.size());
      const double up =
          fit.Project(centre).y() - fit.Project(centre + Vector3d(0, 0, 1.0 / fit.ws)).y();
      candidates.push_back({perm, fit.rms, std::isfinite(up) ? up : 0.0});
    } while (std::next_permutation(perm.begin(), perm.end()));
    double best_rms = std::numeric_limits<double>::infinity();
    for (const auto& c : candidates) best_rms = std::min(best_rms, c.rms);
    const Candidate* chosen = nullptr;
    for (const auto& c : candidates) {
      if (c.rms <= 1.5 * best_rms + 0.05 && (!chosen || c.up > chosen->up)) chosen = &c;
    }
    for (size_t g = 0; g < found.size(); ++g) assign[g] = chosen->perm[g];
  }
  std::vector<char> have(target.points.size(), 0);
  for (size_t g = 0; g < found.size(); ++g) {
    const Grid& grid = layout.grids[assign[g]];
    for (int c = 0; c < n * n; ++c) {
      const int b = found[g].blob_of_cell[c];
      if (b < 0) continue;
      if (claims[b] > 1) {
        out.conflicting_ids.push_back(grid.ids[c]);
        continue;
      }
      if (blobs[b].cut) continue;  // cut by the image border: reported missing
      out.points.push_back({grid.ids[c], blobs[b].centre});
      have[target.Find(grid.ids[c])] = 1;
    }
  }
  for (const Grid& grid : layout.grids) {
    for (const int id : grid.ids) {
      if (!have[target.Find(id)]) out.missing_ids.push_back(id);
    }
  }
  std::sort(out.points.begin(), out.points.end(),
            [](const auto& a, const auto& b) { return a.id < b.id; });
  return out;
}

bool DetectChessboard(const cv::Mat& gray, const ChessboardOptions& options,
                      std::vector<Eigen::Vector2d>* corners) {
  options.Check();
  const cv::Size size(options.inner_corners_x, options.inner_corners_y);
  std::vector<cv::Point2f> found;
  if (!cv::findChessboardCorners(gray, size, found,
                                 cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE)) {
    return false;
  }
  const int half = options.subpix_window_px / 2;
  cv::cornerSubPix(gray, found, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
  corners->clear();
  for (const auto& p : found) corners->emplace_back(p.x, p.y);
  return true;
}

}  // namespace dome::calib
