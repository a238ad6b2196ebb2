// Accuracy measurements of multi-baseline stereo (issue 6 acceptance), one program:
//
//   stereo_accuracy synth TAKE [WINDOWS...]     every camera of a synthetic take's first
//       instant against truth/<instant>/depth/<camera>.tiff: median |error|, fraction of
//       valid pixels within 1% of the truth on textured surfaces, density, and the
//       fattening / thinning at depth discontinuities in pixels, per window size.
//   stereo_accuracy robovision TAKE [WINDOWS...]   a `dome import halcon` take: each
//       camera with its two ring neighbours against the reference cloud projected into
//       it (median relative error, fraction within 1%).
//   stereo_accuracy temple TAKE [WINDOWS...]    Middlebury templeSparseRing imported with
//       `dome import middlebury`: each view with its two nearest ring neighbours, depth
//       searched over 0.75..1.5 times the depth range of the published bounding box;
//       per view the density (valid pixels / all pixels) and the fraction of valid depths
//       whose back-projection falls inside the bounding box enlarged by 5% of its size
//       on every side.
//   stereo_accuracy aloe DIR                    Middlebury Aloe (DIR/aloeL.jpg, aloeR.jpg,
//       aloeGT.png): bad-pixel rates (> 1 px, > 2 px) over ground-truth pixels given a
//       value, and density, for dome's stereo, OpenCV StereoBM and StereoSGBM.
//
// Textured surface: truth has a surface inside the searched range z_min..z_max and the
// reference image's 7x7 grey standard deviation is at least 4 grey levels.
//
// Fattening / thinning at depth discontinuities (seed Figure 4), in pixels, signed:
//   * a discontinuity is a pair of 4-adjacent pixels p (near side) and q = p + d (far
//     side) whose truths differ by more than 5% (t(p) < 0.95 t(q)), or where q has no
//     surface; z_mid is the midpoint of t(p) and t(q) in inverse depth (2 t(p) when q
//     has no surface);
//   * fattening f: walking from q along d, the number of consecutive pixels (at most 10,
//     while the truth stays on the far side) whose estimate is valid and nearer than
//     z_mid: how far the near surface bleeds into the far region;
//   * thinning t: when f = 0, walking from p along -d, the number of consecutive pixels
//     (at most 10, while the truth stays within 5% of t(p)) whose estimate is valid and
//     farther than z_mid: how far the far surface eats into the near region;
//   * the boundary shift of the pair is f - t (> 0: fattened). A pixel without an
//     estimate ends a walk: invalid is neither fat nor thin.
// Reported per camera and window: the mean shift, the mean f and the mean t over all
// pairs, and the fraction of pairs whose q has no estimate.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/timer.h"
#include "io/depth_tiff.h"
#include "io/ply.h"
#include "stereo/multi_baseline.h"
#include "stereo/take_stereo.h"
#include "take/take.h"

namespace {

using namespace dome;

double Median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Reliability thresholds from the environment, for sweeps:
// DOME_STEREO_MIN_UNIQUENESS, DOME_STEREO_MIN_CURVATURE, DOME_STEREO_MIN_TEXTURE; and
// DOME_STEREO_PREWARP=0|1 (StereoOptions::prewarp_neighbours) to compare the warps.
void ApplyEnvOverrides(stereo::StereoOptions* o) {
  if (const char* v = std::getenv("DOME_STEREO_MIN_UNIQUENESS")) o->min_uniqueness = std::atof(v);
  if (const char* v = std::getenv("DOME_STEREO_MIN_CURVATURE")) o->min_curvature = std::atof(v);
  if (const char* v = std::getenv("DOME_STEREO_MIN_TEXTURE")) o->min_texture_grey = std::atof(v);
  if (const char* v = std::getenv("DOME_STEREO_PREWARP")) o->prewarp_neighbours = std::atoi(v) != 0;
  std::printf("thresholds: min_uniqueness %g, min_curvature %g, min_texture_grey %g; %s warp\n",
              o->min_uniqueness, o->min_curvature, o->min_texture_grey,
              o->prewarp_neighbours ? "pre-warped" : "exact");
}

struct SynthScore {
  double median_abs_mm = NAN, within1 = NAN, density = NAN;
  double shift_px = NAN, fatten_px = NAN, thin_px = NAN, edge_invalid = NAN;
};

SynthScore ScoreSynth(const cv::Mat& est, const cv::Mat& truth, const cv::Mat& ref_grey,
                      double z_min_mm, double z_max_mm) {
  SynthScore s;
  cv::Mat g, mean, mean2;
  ref_grey.convertTo(g, CV_32F);
  cv::boxFilter(g, mean, CV_32F, cv::Size(7, 7));
  cv::boxFilter(g.mul(g), mean2, CV_32F, cv::Size(7, 7));
  std::vector<double> errs;
  int64_t n_textured = 0, n_within = 0, n_valid = 0;
  for (int y = 0; y < est.rows; ++y) {
    for (int x = 0; x < est.cols; ++x) {
      const float t = truth.at<float>(y, x), e = est.at<float>(y, x);
      const float var = mean2.at<float>(y, x) - mean.at<float>(y, x) * mean.at<float>(y, x);
      // Only surfaces inside the searched depth range can be recovered.
      if (t < z_min_mm || t > z_max_mm || var < 16.0f) continue;
      ++n_textured;
      if (e <= 0) continue;
      ++n_valid;
      errs.push_back(std::abs(e - t));
      if (std::abs(e - t) <= 0.01 * t) ++n_within;
    }
  }
  s.median_abs_mm = Median(errs);
  s.within1 = n_valid ? double(n_within) / n_valid : NAN;
  s.density = n_textured ? double(n_valid) / n_textured : NAN;
  // Discontinuities (definition at the top of the file).
  const int W = truth.cols, H = truth.rows;
  auto inv = [](float z) { return z > 0 ? 1.0 / z : 0.0; };
  int64_t pairs = 0, q_invalid = 0;
  double sum_f = 0, sum_t = 0;
  const int dxs[4] = {1, -1, 0, 0}, dys[4] = {0, 0, 1, -1};
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      const float tp = truth.at<float>(y, x);
      if (!(tp > 0)) continue;
      for (int k = 0; k < 4; ++k) {
        const int qx = x + dxs[k], qy = y + dys[k];
        if (qx < 0 || qy < 0 || qx >= W || qy >= H) continue;
        const float tq = truth.at<float>(qy, qx);
        if (tq > 0 && !(tp < 0.95f * tq)) continue;
        ++pairs;
        const double w_mid = 0.5 * (inv(tp) + inv(tq));  // inverse depth
        q_invalid += !(est.at<float>(qy, qx) > 0);
        int f = 0;
        for (int i = 0; i < 10; ++i) {
          const int xx = qx + i * dxs[k], yy = qy + i * dys[k];
          if (xx < 0 || yy < 0 || xx >= W || yy >= H) break;
          const float t = truth.at<float>(yy, xx), e = est.at<float>(yy, xx);
          if (t > 0 && !(tp < 0.95f * t)) break;  // left the far side
          if (!(e > 0) || !(1.0 / e > w_mid)) break;
          ++f;
        }
        int th = 0;
        if (f == 0) {
          for (int i = 0; i < 10; ++i) {
            const int xx = x - i * dxs[k], yy = y - i * dys[k];
            if (xx < 0 || yy < 0 || xx >= W || yy >= H) break;
            const float t = truth.at<float>(yy, xx), e = est.at<float>(yy, xx);
            if (!(t > 0) || std::abs(t - tp) > 0.05f * tp) break;  // left the near side
            if (!(e > 0) || !(1.0 / e < w_mid)) break;
            ++th;
          }
        }
        sum_f += f;
        sum_t += th;
      }
    }
  }
  if (pairs == 0) return s;
  s.fatten_px = sum_f / pairs;
  s.thin_px = sum_t / pairs;
  s.shift_px = (sum_f - sum_t) / pairs;
  s.edge_invalid = double(q_invalid) / pairs;
  return s;
}

int RunSynth(const std::string& take_dir, std::vector<int> windows) {
  const take::Take take = take::OpenTake(take_dir);
  const std::string instant = take.instants.front();
  stereo::TakeStereoOptions opt;
  if (!windows.empty()) opt.stereo.window_sizes_px = windows;
  opt.stereo.num_threads = 2;
  ApplyEnvOverrides(&opt.stereo);
  const size_t nw = opt.stereo.window_sizes_px.size();
  std::vector<std::vector<SynthScore>> all(nw);
  std::printf(
      "camera window levels median_abs_mm within1%% density shift_px fatten_px thin_px "
      "edge_invalid match_ms\n");
  for (const auto& cam : take.rig.cameras) {
    const auto input = stereo::LoadStereoInput(take, instant, cam.model.id, opt.cluster);
    const auto r = stereo::ComputeDepth(input, opt.stereo);
    const cv::Mat truth = io::ReadDepthTiff(take.TruthDepthPath(instant, cam.model.id));
    cv::Mat grey;
    if (input.reference.image.channels() == 1)
      grey = input.reference.image;
    else
      cv::cvtColor(input.reference.image, grey, cv::COLOR_BGR2GRAY);
    for (size_t k = 0; k < nw; ++k) {
      const SynthScore s = ScoreSynth(r.range_images[k].depth_mm, truth, grey, opt.stereo.z_min_mm,
                                      opt.stereo.z_max_mm);
      all[k].push_back(s);
      std::printf("%s %d %d %.2f %.4f %.4f %.2f %.2f %.2f %.3f %.1f\n", cam.model.id.c_str(),
                  r.range_images[k].window_px, r.num_levels, s.median_abs_mm, s.within1, s.density,
                  s.shift_px, s.fatten_px, s.thin_px, s.edge_invalid, 1e3 * r.match_seconds);
    }
  }
  std::printf("\nsummary over %zu cameras (median of per-camera values)\n",
              take.rig.cameras.size());
  std::printf("window median_abs_mm within1%% density shift_px fatten_px thin_px edge_invalid\n");
  for (size_t k = 0; k < nw; ++k) {
    auto col = [&](auto f) {
      std::vector<double> v;
      for (const auto& s : all[k])
        if (std::isfinite(f(s))) v.push_back(f(s));
      return Median(v);
    };
    std::printf("%d %.2f %.4f %.4f %.2f %.2f %.2f %.3f\n", opt.stereo.window_sizes_px[k],
                col([](const SynthScore& s) { return s.median_abs_mm; }),
                col([](const SynthScore& s) { return s.within1; }),
                col([](const SynthScore& s) { return s.density; }),
                col([](const SynthScore& s) { return s.shift_px; }),
                col([](const SynthScore& s) { return s.fatten_px; }),
                col([](const SynthScore& s) { return s.thin_px; }),
                col([](const SynthScore& s) { return s.edge_invalid; }));
  }
  return 0;
}

struct BadPixels {
  double bad1 = 0, bad2 = 0, density = 0;
};

// disp: CV_32F, <= 0 = no value. gt: 8-bit, 0 = unknown.
BadPixels ScoreDisparity(const cv::Mat& disp, const cv::Mat& gt) {
  int64_t n_gt = 0, n = 0, b1 = 0, b2 = 0;
  for (int y = 0; y < gt.rows; ++y) {
    for (int x = 0; x < gt.cols; ++x) {
      const int g = gt.at<uint8_t>(y, x);
      if (g == 0) continue;
      ++n_gt;
      const float d = disp.at<float>(y, x);
      if (!(d > 0)) continue;
      ++n;
      const double e = std::abs(d - g);
      b1 += e > 1.0;
      b2 += e > 2.0;
    }
  }
  BadPixels r;
  r.density = double(n) / n_gt;
  r.bad1 = n ? double(b1) / n : NAN;
  r.bad2 = n ? double(b2) / n : NAN;
  return r;
}

int RunAloe(const std::string& dir, std::vector<int> windows) {
  const cv::Mat left = cv::imread(dir + "/aloeL.jpg", cv::IMREAD_GRAYSCALE);
  const cv::Mat right = cv::imread(dir + "/aloeR.jpg", cv::IMREAD_GRAYSCALE);
  const cv::Mat gt = cv::imread(dir + "/aloeGT.png", cv::IMREAD_GRAYSCALE);
  core::Require(!left.empty() && !right.empty() && !gt.empty(), dir, "Aloe files missing");
  double gmin, gmax;
  cv::minMaxLoc(gt, &gmin, &gmax, nullptr, nullptr, gt > 0);
  const int num_disp = 16 * int(std::ceil((gmax + 8) / 16.0));
  std::printf("Aloe %dx%d, ground truth disparities %.0f..%.0f px, search 0..%d\n", left.cols,
              left.rows, gmin, gmax, num_disp);
  std::printf("method bad>1px bad>2px density ms\n");
  // dome: binocular special case. Left = reference at the origin, right 100 mm to its
  // right, f = 1000 px: z = f B / d. Search d in [1, num_disp].
  const double f = 1000.0, b = 100.0;
  auto cam = [&](const std::string& id, double cx_mm) {
    geometry::TsaiCamera c;
    c.id = id;
    c.width_px = left.cols;
    c.height_px = left.rows;
    c.sensor = {double(left.cols), double(left.cols), 0.01, 0.01};
    c.focal_mm = f * 0.01;
    c.cx_px = left.cols / 2.0;
    c.cy_px = left.rows / 2.0;
    c.translation_mm = Eigen::Vector3d(-cx_mm, 0, 0);
    return c;
  };
  stereo::StereoInput in;
  in.reference = {cam("left", 0), left, {}};
  in.neighbours.push_back({cam("right", b), right, {}});
  // Both profiles: the defaults and RealImageOptions() (multi_baseline.h).
  for (const bool real : {false, true}) {
    stereo::StereoOptions opt = real ? stereo::RealImageOptions() : stereo::StereoOptions{};
    opt.z_min_mm = f * b / num_disp;
    opt.z_max_mm = f * b / 1.0;
    opt.num_threads = 2;
    if (!windows.empty()) {
      opt.window_sizes_px = windows;
    } else if (!real) {
      opt.window_sizes_px = {5, 9, 13};
    }
    ApplyEnvOverrides(&opt);
    core::Stopwatch sw;
    const auto r = stereo::ComputeDepth(in, opt);
    const double ms = 1e3 * sw.ElapsedSeconds();
    for (const auto& ri : r.range_images) {
      cv::Mat disp(ri.depth_mm.size(), CV_32F, cv::Scalar(0));
      for (int y = 0; y < disp.rows; ++y)
        for (int x = 0; x < disp.cols; ++x) {
          const float z = ri.depth_mm.at<float>(y, x);
          if (z > 0) disp.at<float>(y, x) = float(f * b / z);
        }
      const BadPixels s = ScoreDisparity(disp, gt);
      std::printf("dome_%s_w%d(%d_levels) %.4f %.4f %.4f %.0f(all_windows)\n",
                  real ? "real" : "default", ri.window_px, r.num_levels, s.bad1, s.bad2, s.density,
                  ms);
    }
  }
  core::Stopwatch sw;
  cv::setNumThreads(2);
  for (int block : {9, 15, 21}) {
    auto bm = cv::StereoBM::create(num_disp, block);
    cv::Mat d16, d;
    sw.Restart();
    bm->compute(left, right, d16);
    const double t = 1e3 * sw.ElapsedSeconds();
    d16.convertTo(d, CV_32F, 1.0 / 16);
    const BadPixels s = ScoreDisparity(d, gt);
    std::printf("StereoBM_b%d %.4f %.4f %.4f %.0f\n", block, s.bad1, s.bad2, s.density, t);
  }
  {
    auto sg = cv::StereoSGBM::create(0, num_disp, 5, 8 * 25, 32 * 25, 1, 63, 10, 100, 32);
    cv::Mat d16, d;
    sw.Restart();
    sg->compute(left, right, d16);
    const double t = 1e3 * sw.ElapsedSeconds();
    d16.convertTo(d, CV_32F, 1.0 / 16);
    const BadPixels s = ScoreDisparity(d, gt);
    std::printf("StereoSGBM_b5 %.4f %.4f %.4f %.0f\n", s.bad1, s.bad2, s.density, t);
  }
  return 0;
}

// A Robovision take (dome import halcon): each camera with its two ring neighbours
// (nearest centres), depth range from the reference cloud seen by the camera (+-5%),
// contrast normalization on; error against the reference cloud z-buffered into the
// reference camera (nearest point per pixel, pixels behind a nearer point within 7x7
// dropped: the cloud is sparse and would otherwise show the far side through gaps).
int RunRobovision(const std::string& take_dir, std::vector<int> windows) {
  const take::Take take = take::OpenTake(take_dir);
  const std::string instant = take.instants.front();
  const io::Mesh cloud = io::ReadPly(take.dir / "reference" / "reference.ply");
  const double unit_mm = take.rig.source_unit_mm;
  stereo::TakeStereoOptions opt;
  opt.stereo.window_sizes_px = windows.empty() ? std::vector<int>{9} : windows;
  opt.stereo.normalize_contrast = true;
  opt.stereo.num_threads = 2;
  opt.cluster.max_neighbours = 2;
  ApplyEnvOverrides(&opt.stereo);
  std::printf("camera window levels median_rel_err within1%% compared_px ref_px match_s\n");
  std::vector<double> med_all, within_all;
  for (const auto& cam : take.rig.cameras) {
    const auto& c = cam.model;
    cv::Mat zbuf(c.height_px, c.width_px, CV_32F, cv::Scalar(0));
    double zmin = 1e30, zmax = 0;
    for (const auto& v : cloud.vertices) {
      const Eigen::Vector3d w = v.cast<double>() * unit_mm;
      const Eigen::Vector3d pc = c.WorldToCamera(w);
      Eigen::Vector2d px;
      if (!c.ProjectCamera(pc, &px)) continue;
      const int x = int(std::lround(px.x())), y = int(std::lround(px.y()));
      if (x < 0 || y < 0 || x >= c.width_px || y >= c.height_px) continue;
      float& z = zbuf.at<float>(y, x);
      if (z == 0 || pc.z() < z) z = float(pc.z());
      zmin = std::min(zmin, pc.z());
      zmax = std::max(zmax, pc.z());
    }
    // The cloud is sparse: where a pixel got only a point of the far side, a nearer
    // point lands next to it. Keep pixels within 1% of the nearest point in 7x7.
    {
      cv::Mat big = zbuf.clone();
      big.setTo(1e9f, zbuf == 0);
      cv::Mat local_min;
      cv::erode(big, local_min, cv::Mat::ones(7, 7, CV_8U));
      zbuf.setTo(0.0f, zbuf > local_min * 1.01);
    }
    stereo::TakeStereoOptions o = opt;
    o.stereo.z_min_mm = 0.95 * zmin;
    o.stereo.z_max_mm = 1.05 * zmax;
    const auto input = stereo::LoadStereoInput(take, instant, c.id, o.cluster);
    const auto r = stereo::ComputeDepth(input, o.stereo);
    for (const auto& ri : r.range_images) {
      std::vector<double> rel;
      int64_t n_ref = 0, within = 0;
      for (int y = 0; y < zbuf.rows; ++y)
        for (int x = 0; x < zbuf.cols; ++x) {
          const float zr = zbuf.at<float>(y, x);
          if (zr <= 0) continue;
          ++n_ref;
          const float ze = ri.depth_mm.at<float>(y, x);
          if (ze <= 0) continue;
          const double e = std::abs(ze - zr) / zr;
          rel.push_back(e);
          within += e <= 0.01;
        }
      const double med = Median(rel), wf = rel.empty() ? NAN : double(within) / rel.size();
      std::printf("%s %d %d %.4f %.4f %zu %lld %.1f\n", c.id.c_str(), ri.window_px, r.num_levels,
                  med, wf, rel.size(), (long long)n_ref, r.match_seconds);
      std::fflush(stdout);
      if (ri.window_px == o.stereo.window_sizes_px.front()) {
        med_all.push_back(med);
        within_all.push_back(wf);
      }
    }
  }
  std::printf("median over cameras (first window): median_rel_err %.4f within1%% %.4f\n",
              Median(med_all), Median(within_all));
  return 0;
}

// templeSparseRing's published tight bounding box (its README), in the take's source
// unit (metres).
constexpr double kTempleBoxMin[3] = {-0.073568, 0.021728, -0.012445};
constexpr double kTempleBoxMax[3] = {0.028855, 0.181892, 0.062736};

int RunTemple(const std::string& take_dir, std::vector<int> windows) {
  const take::Take take = take::OpenTake(take_dir);
  const std::string instant = take.instants.front();
  const double unit_mm = take.rig.source_unit_mm;
  Eigen::Vector3d lo, hi;  // the box enlarged by 5% of its size on every side, mm
  for (int a = 0; a < 3; ++a) {
    const double size = kTempleBoxMax[a] - kTempleBoxMin[a];
    lo[a] = (kTempleBoxMin[a] - 0.05 * size) * unit_mm;
    hi[a] = (kTempleBoxMax[a] + 0.05 * size) * unit_mm;
  }
  stereo::TakeStereoOptions opt;
  opt.stereo.window_sizes_px = windows.empty() ? std::vector<int>{9} : windows;
  opt.stereo.num_threads = 2;
  opt.cluster.max_neighbours = 2;
  ApplyEnvOverrides(&opt.stereo);
  std::printf("view window levels z_min_mm z_max_mm valid_px density inside_box match_s\n");
  const size_t nw = opt.stereo.window_sizes_px.size();
  std::vector<std::vector<double>> dens(nw), inside(nw);
  std::vector<int64_t> total_valid(nw, 0), total_inside(nw, 0);
  for (const auto& cam : take.rig.cameras) {
    const auto& c = cam.model;
    double zmin = 1e30, zmax = 0;
    for (int k = 0; k < 8; ++k) {
      const Eigen::Vector3d corner((k & 1 ? kTempleBoxMax[0] : kTempleBoxMin[0]) * unit_mm,
                                   (k & 2 ? kTempleBoxMax[1] : kTempleBoxMin[1]) * unit_mm,
                                   (k & 4 ? kTempleBoxMax[2] : kTempleBoxMin[2]) * unit_mm);
      const double z = c.WorldToCamera(corner).z();
      zmin = std::min(zmin, z);
      zmax = std::max(zmax, z);
    }
    stereo::TakeStereoOptions o = opt;
    o.stereo.z_min_mm = 0.75 * zmin;
    o.stereo.z_max_mm = 1.5 * zmax;
    const auto input = stereo::LoadStereoInput(take, instant, c.id, o.cluster);
    const auto r = stereo::ComputeDepth(input, o.stereo);
    for (size_t k = 0; k < nw; ++k) {
      const cv::Mat& d = r.range_images[k].depth_mm;
      int64_t valid = 0, in_box = 0;
      for (int y = 0; y < d.rows; ++y) {
        for (int x = 0; x < d.cols; ++x) {
          const float z = d.at<float>(y, x);
          if (!(z > 0)) continue;
          ++valid;
          const Eigen::Vector3d p = c.BackProjectAtDepth(Eigen::Vector2d(x, y), z);
          in_box += (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all();
        }
      }
      const double density = double(valid) / d.total();
      const double frac = valid ? double(in_box) / valid : NAN;
      dens[k].push_back(density);
      inside[k].push_back(frac);
      total_valid[k] += valid;
      total_inside[k] += in_box;
      std::printf("%s %d %d %.0f %.0f %lld %.4f %.4f %.1f\n", c.id.c_str(),
                  r.range_images[k].window_px, r.num_levels, o.stereo.z_min_mm, o.stereo.z_max_mm,
                  (long long)valid, density, frac, r.match_seconds);
      std::fflush(stdout);
    }
  }
  for (size_t k = 0; k < nw; ++k) {
    std::printf(
        "window %d over %zu views: median density %.4f, median inside_box %.4f, pooled "
        "inside_box %.4f\n",
        opt.stereo.window_sizes_px[k], dens[k].size(), Median(dens[k]), Median(inside[k]),
        total_valid[k] ? double(total_inside[k]) / total_valid[k] : NAN);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc < 3) {
      std::fprintf(stderr,
                   "usage: stereo_accuracy synth TAKE | robovision TAKE | temple TAKE | aloe DIR "
                   "[WINDOWS...]\n");
      return 2;
    }
    std::vector<int> windows;
    for (int i = 3; i < argc; ++i) windows.push_back(std::atoi(argv[i]));
    const std::string mode = argv[1];
    if (mode == "synth") return RunSynth(argv[2], windows);
    if (mode == "aloe") return RunAloe(argv[2], windows);
    if (mode == "robovision") return RunRobovision(argv[2], windows);
    if (mode == "temple") return RunTemple(argv[2], windows);
    std::fprintf(stderr, "unknown mode '%s'\n", mode.c_str());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
