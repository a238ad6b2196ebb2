#include "mesh/texture.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/parallel_for.h"
#include "geometry/raster.h"
#include "geometry/undistort.h"
#include "io/file_util.h"
#include "io/image_io.h"

namespace dome::mesh {
namespace {

// One camera's constants for the fast path, contiguous and by value.
//
// Its projection is TsaiCamera::ProjectCamera rearranged: with x = kappa1 Ru^2 the
// distortion factor lambda = Rd / Ru is the root near 1 of x lambda^3 + lambda - 1 = 0,
// found from its series 1 - x + 3x^2 - 12x^3 + 55x^4 - 273x^5 (relative error < 4e-5
// for |x| <= 0.05; the paper rig's image corners are at ~0.03) and two Newton steps
// (each squares the error times ~3|x|: < 3e-10, then rounding), with no square root,
// sinh or asinh; the closed form (geometry::DistortedRadiusMm) beyond. The pixel agrees
// with ProjectCamera's to within rounding (~1e-13 px).
struct FastView {
  double rotation[9] = {};  // world -> camera, row-major
  double translation_mm[3] = {};
  double centre[3] = {};  // camera centre, world mm
  double focal_mm = 0, kappa1 = 0;
  double px_per_mm_x = 1, px_per_mm_y = 1;  // sx / dpx, 1 / dpy
  double cx_px = 0, cy_px = 0;
  int width = 0, height = 0;
  const float* zbuffer = nullptr;  // ShadingView::zbuffer
  const uint8_t* bgr = nullptr;    // ShadingView::bgr, rows of bgr_step bytes
  size_t bgr_step = 0;

  explicit FastView(const geometry::TsaiCamera& cam)
      : focal_mm(cam.focal_mm),
        kappa1(cam.kappa1_per_mm2),
        px_per_mm_x(cam.sx / cam.sensor.dpx_mm()),
        px_per_mm_y(1.0 / cam.sensor.dpy_mm()),
        cx_px(cam.cx_px),
        cy_px(cam.cy_px),
        width(cam.width_px),
        height(cam.height_px) {
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) rotation[3 * r + c] = cam.rotation(r, c);
      translation_mm[r] = cam.translation_mm[r];
    }
    const Eigen::Vector3d centre_world = cam.CentreWorld();
    for (int r = 0; r < 3; ++r) centre[r] = centre_world[r];
  }
  FastView() = default;

  // Rd / Ru at undistorted sensor radius^2 `ru2` (mm^2).
  double DistortionFactor(double ru2) const {
    const double x = kappa1 * ru2;
    if (!(std::abs(x) <= 0.05)) {
      const double ru = std::sqrt(ru2);
      double rd;
      geometry::DistortedRadiusMm(ru, kappa1, &rd);
      return ru > 0.0 ? rd / ru : 1.0;
    }
    double lambda = 1.0 + x * (-1.0 + x * (3.0 + x * (-12.0 + x * (55.0 - 273.0 * x))));
    for (int i = 0; i < 2; ++i) {
      const double xl2 = x * lambda * lambda;
      lambda -= (xl2 * lambda + lambda - 1.0) / (3.0 * xl2 + 1.0);
    }
    return lambda;
  }

  // Camera-frame point (mm) -> distorted pixel; false when z <= 0.
  bool Project(double x, double y, double z, double* px, double* py) const {
    if (!(z > 0.0)) return false;
    const double scale = focal_mm / z;
    const double xu = x * scale, yu = y * scale;
    const double lambda = DistortionFactor(xu * xu + yu * yu);
    *px = xu * lambda * px_per_mm_x + cx_px;
    *py = yu * lambda * px_per_mm_y + cy_px;
    return true;
  }
};

// One camera prepared for shading: colour image, z-buffer of the mesh, centre.
struct ShadingView {
  const geometry::TsaiCamera* camera = nullptr;
  FastView fast;
  cv::Mat bgr;                 // CV_8UC3
  std::vector<float> zbuffer;  // camera z of the nearest mesh surface per pixel, mm
  Eigen::Vector3d centre;
  // The mesh's vertices in this camera's frame, mm (for the per-face culling only).
  std::vector<Eigen::Vector3d> vertex_camera;
};

// Renders the mesh's camera depth into a z-buffer: vertices are projected with
// distortion, triangles filled in pixel space with z interpolated linearly.
// Sets *vertex_camera to the vertices in the camera frame (mm) when not null. `exact`:
// TsaiCamera::ProjectCamera, else `fast`'s projection. `scratch` is reused
// across views.
std::vector<float> RenderZBuffer(const geometry::TsaiCamera& cam, const FastView& fast, bool exact,
                                 const io::Mesh& mesh, std::vector<Eigen::Vector3d>* vertex_camera,
                                 std::vector<Eigen::Vector3d>* scratch) {
  const int w = cam.width_px, h = cam.height_px;
  std::vector<float> zbuf(size_t(w) * h, std::numeric_limits<float>::infinity());
  std::vector<Eigen::Vector3d>& proj = *scratch;
  proj.resize(mesh.vertices.size());
  if (vertex_camera) vertex_camera->resize(mesh.vertices.size());
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    const Eigen::Vector3d c = cam.WorldToCamera(mesh.vertices[v].cast<double>());
    if (vertex_camera) (*vertex_camera)[v] = c;
    Eigen::Vector2d px;
    const bool in_front =
        exact ? cam.ProjectCamera(c, &px) : fast.Project(c.x(), c.y(), c.z(), &px.x(), &px.y());
    proj[v] = in_front ? Eigen::Vector3d(px.x(), px.y(), c.z()) : Eigen::Vector3d(0, 0, -1);
  }
  for (const auto& f : mesh.faces) {
    const Eigen::Vector3d& a = proj[f[0]];
    const Eigen::Vector3d& b = proj[f[1]];
    const Eigen::Vector3d& c = proj[f[2]];
    if (a.z() <= 0 || b.z() <= 0 || c.z() <= 0) continue;
    geometry::RasterizeTriangle(a.head<2>(), b.head<2>(), c.head<2>(), w, h, /*divide=*/exact,
                                [&](int x, int y, double wa, double wb, double wc) {
                                  const float z = float(wa * a.z() + wb * b.z() + wc * c.z());
                                  float& dst = zbuf[size_t(y) * w + x];
                                  dst = std::min(dst, z);
                                });
  }
  return zbuf;
}

// Views of cameras with an OpenCV lens resampled once into their ideal cameras (the
// exact lens through geometry/undistort.h's tables), so that the projections below,
// written for Tsai's radial model, hold for every view.
std::vector<TextureView> IdealViews(const std::vector<TextureView>& views) {
  std::vector<TextureView> out = views;
  for (auto& v : out) {
    if (!v.camera.lens.Any()) continue;
    v.image = geometry::Remap(v.image, *geometry::SharedUndistortTables(v.camera));
    v.camera.lens = {};
  }
  return out;
}

// Everything shading needs, prepared once per mesh: the views resampled to Tsai's model
// (IdealViews), each with its z-buffer, their FastViews, and with `for_atlas` the
// vertices in each camera frame (the atlas's per-face culling).
struct Prepared {
  std::vector<TextureView> ideal;
  std::vector<ShadingView> views;
  std::vector<FastView> fast;
};

Prepared Prepare(const io::Mesh& mesh, const std::vector<TextureView>& views,
                 const TextureOptions& options, bool for_atlas) {
  options.Check();
  for (const auto& v : views) CheckTextureView(v);
  Prepared p;
  p.ideal = IdealViews(views);
  const bool exact = options.exhaustive;
  const bool keep_vertices = for_atlas && !exact;
  std::vector<ShadingView>& out = p.views;
  out.resize(p.ideal.size());
  core::ParallelFor(0, int64_t(p.ideal.size()), options.num_threads, [&](int64_t b, int64_t e) {
    std::vector<Eigen::Vector3d> proj;
    for (int64_t i = b; i < e; ++i) {
      const TextureView& view = p.ideal[i];
      out[i].camera = &view.camera;
      out[i].fast = FastView(view.camera);
      if (view.image.channels() == 1) {
        cv::cvtColor(view.image, out[i].bgr, cv::COLOR_GRAY2BGR);
      } else {
        out[i].bgr = view.image;
      }
      out[i].zbuffer = RenderZBuffer(view.camera, out[i].fast, exact, mesh,
                                     keep_vertices ? &out[i].vertex_camera : nullptr, &proj);
      out[i].centre = view.camera.CentreWorld();
      out[i].fast.zbuffer = out[i].zbuffer.data();
      out[i].fast.bgr = out[i].bgr.ptr<uint8_t>(0);
      out[i].fast.bgr_step = out[i].bgr.step[0];
    }
  });
  for (const auto& v : out) p.fast.push_back(v.fast);
  return p;
}

// Weighted mean colour (BGR, 0..255) of point p with unit normal n; false if unseen.
// The exhaustive reference: every view, TsaiCamera::ProjectCamera.
bool Shade(const Eigen::Vector3d& p, const Eigen::Vector3d& n,
           const std::vector<ShadingView>& views, const TextureOptions& options,
           Eigen::Vector3d* bgr) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double wsum = 0.0;
  for (const ShadingView& v : views) {
    const Eigen::Vector3d to_cam = (v.centre - p).normalized();
    const double cos_angle = n.dot(to_cam);
    if (!(cos_angle >= options.min_cos_angle)) continue;
    const Eigen::Vector3d c = v.camera->WorldToCamera(p);
    Eigen::Vector2d px;
    if (!v.camera->ProjectCamera(c, &px)) continue;
    const int w = v.bgr.cols, h = v.bgr.rows;
    if (!(px.x() >= 0 && px.y() >= 0 && px.x() <= w - 1 && px.y() <= h - 1)) continue;
    const int xi = int(std::lround(px.x())), yi = int(std::lround(px.y()));
    if (c.z() > v.zbuffer[size_t(yi) * w + xi] + options.depth_tolerance_mm) continue;
    const int x0 = std::min(int(px.x()), w - 2), y0 = std::min(int(px.y()), h - 2);
    const double ax = px.x() - x0, ay = px.y() - y0;
    Eigen::Vector3d colour = Eigen::Vector3d::Zero();
    for (int dy = 0; dy < 2; ++dy) {
      for (int dx = 0; dx < 2; ++dx) {
        const cv::Vec3b s = v.bgr.at<cv::Vec3b>(y0 + dy, x0 + dx);
        const double wt = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
        colour += wt * Eigen::Vector3d(s[0], s[1], s[2]);
      }
    }
    const double wt = cos_angle * cos_angle;
    sum += wt * colour;
    wsum += wt;
  }
  if (wsum <= 0.0) return false;
  *bgr = sum / wsum;
  return true;
}

// std::lround for x >= 0, inline (x - int(x) is exact).
inline int RoundNonNegative(double x) {
  const int i = int(x);
  return x - i >= 0.5 ? i + 1 : i;
}

// Shade's depth test and bilinear sample at pixel (x, y), inside the image, of a point
// at camera depth z_mm: adds the colour weighted by `weight` (cos_angle^2) to sum[0..2]
// and the weight to *wsum; nothing when the z-buffer hides the point.
__attribute__((always_inline)) inline void AddSample(const FastView& v, double x, double y, double z_mm, double weight,
                      const TextureOptions& options, double* s0, double* s1, double* s2,
                      double* wsum) {
  const int w = v.width;
  const int xi = RoundNonNegative(x), yi = RoundNonNegative(y);
  if (z_mm > v.zbuffer[size_t(yi) * w + xi] + options.depth_tolerance_mm) return;
  const int x0 = std::min(int(x), w - 2), y0 = std::min(int(y), v.height - 2);
  const double ax = x - x0, ay = y - y0;
  const uint8_t* top = v.bgr + size_t(y0) * v.bgr_step + 3 * size_t(x0);
  const uint8_t* bottom = top + v.bgr_step;
  const double w00 = (1 - ax) * (1 - ay), w01 = ax * (1 - ay), w10 = (1 - ax) * ay, w11 = ax * ay;
  const double wt = weight;
  *s0 += wt * (w00 * top[0] + w01 * top[3] + w10 * bottom[0] + w11 * bottom[3]);
  *s1 += wt * (w00 * top[1] + w01 * top[4] + w10 * bottom[1] + w11 * bottom[4]);
  *s2 += wt * (w00 * top[2] + w01 * top[5] + w10 * bottom[2] + w11 * bottom[5]);
  *wsum += wt;
}

// Shade's tests and weights over the views listed in `candidates` (all views when
// null), with FastView's projection and the arithmetic rearranged (one square root
// and one division for the cosine): the same colours to within rounding.
bool ShadeFast(const Eigen::Vector3d& p, const Eigen::Vector3d& n,
               const std::vector<FastView>& views, const std::vector<int>* candidates,
               const TextureOptions& options, Eigen::Vector3d* bgr) {
  double sum0 = 0, sum1 = 0, sum2 = 0, wsum = 0;
  const size_t count = candidates ? candidates->size() : views.size();
  const double px_ = p.x(), py_ = p.y(), pz_ = p.z();
  for (size_t j = 0; j < count; ++j) {
    const FastView& v = views[candidates ? size_t((*candidates)[j]) : j];
    const double dx = v.centre[0] - px_, dy = v.centre[1] - py_, dz = v.centre[2] - pz_;
    const double cos_angle =
        (n.x() * dx + n.y() * dy + n.z() * dz) / std::sqrt(dx * dx + dy * dy + dz * dz);
    if (!(cos_angle >= options.min_cos_angle)) continue;
    const double* r = v.rotation;
    const double cx = r[0] * px_ + r[1] * py_ + r[2] * pz_ + v.translation_mm[0];
    const double cy = r[3] * px_ + r[4] * py_ + r[5] * pz_ + v.translation_mm[1];
    const double cz = r[6] * px_ + r[7] * py_ + r[8] * pz_ + v.translation_mm[2];
    double x, y;
    if (!v.Project(cx, cy, cz, &x, &y)) continue;
    if (!(x >= 0 && y >= 0 && x <= v.width - 1 && y <= v.height - 1)) continue;
    AddSample(v, x, y, cz, cos_angle * cos_angle, options, &sum0, &sum1, &sum2, &wsum);
  }
  if (wsum <= 0.0) return false;
  *bgr = Eigen::Vector3d(sum0, sum1, sum2) / wsum;
  return true;
}

// An atlas texel of one half of a cell: its position in the cell and the barycentric
// weights of its centre (of the face's second and third corner).
struct Texel {
  int tx, ty;
  double w1, w2;
};

// Lanes of the loops over a face's texels that the compiler vectorizes.
constexpr size_t kLanes = 8;

// Per-thread scratch for ShadeFace: per texel, structure of arrays padded to kLanes.
struct FaceScratch {
  std::vector<double> x, y, z;           // texel centre, world mm
  std::vector<double> weight, cz, px, py;  // one view: cos^2 (-1: fails), camera z, pixel
  std::vector<double> distortion;        // one view: kappa1 Ru^2
  std::vector<double> s0, s1, s2, wsum;  // weighted BGR sums and weight sums
  void Resize(size_t n) {
    for (auto* v : {&x, &y, &z, &weight, &cz, &px, &py, &distortion, &s0, &s1, &s2, &wsum}) {
      v->resize(n);
    }
  }
};

// ShadeFast for all texels of one face at once, view by view (the candidates): the
// cosine and projection of every texel in a loop the compiler vectorizes, then the
// tests, depth test and sampling texel by texel. Each texel sums the same terms in the
// same order as ShadeFast. Leaves the sums in scratch->s0, s1, s2 and wsum.
void ShadeFace(const io::Mesh& mesh, const Eigen::Vector3i& face, const Eigen::Vector3d& n,
               const std::vector<Texel>& texels, const std::vector<FastView>& views,
               const std::vector<int>& candidates, const TextureOptions& options,
               FaceScratch* scratch) {
  const size_t count = texels.size();
  const size_t padded = (count + kLanes - 1) / kLanes * kLanes;
  scratch->Resize(padded);
  const Eigen::Vector3d a = mesh.vertices[face[0]].cast<double>();
  const Eigen::Vector3d ab = mesh.vertices[face[1]].cast<double>() - a;
  const Eigen::Vector3d ac = mesh.vertices[face[2]].cast<double>() - a;
  double* __restrict__ X = scratch->x.data();
  double* __restrict__ Y = scratch->y.data();
  double* __restrict__ Z = scratch->z.data();
  for (size_t k = 0; k < padded; ++k) {
    const Texel& t = texels[std::min(k, count - 1)];
    X[k] = a.x() + t.w1 * ab.x() + t.w2 * ac.x();
    Y[k] = a.y() + t.w1 * ab.y() + t.w2 * ac.y();
    Z[k] = a.z() + t.w1 * ab.z() + t.w2 * ac.z();
  }
  std::fill(scratch->s0.begin(), scratch->s0.end(), 0.0);
  std::fill(scratch->s1.begin(), scratch->s1.end(), 0.0);
  std::fill(scratch->s2.begin(), scratch->s2.end(), 0.0);
  std::fill(scratch->wsum.begin(), scratch->wsum.end(), 0.0);
  double* __restrict__ weightv = scratch->weight.data();
  const double min_cos2 = options.min_cos_angle * options.min_cos_angle;
  double* __restrict__ czv = scratch->cz.data();
  double* __restrict__ pxv = scratch->px.data();
  double* __restrict__ pyv = scratch->py.data();
  double* __restrict__ dv = scratch->distortion.data();
  const double nx = n.x(), ny = n.y(), nz = n.z();
  for (const int index : candidates) {
    const FastView& v = views[size_t(index)];
    const double ox = v.centre[0], oy = v.centre[1], oz = v.centre[2];
    const double r0 = v.rotation[0], r1 = v.rotation[1], r2 = v.rotation[2];
    const double r3 = v.rotation[3], r4 = v.rotation[4], r5 = v.rotation[5];
    const double r6 = v.rotation[6], r7 = v.rotation[7], r8 = v.rotation[8];
    const double t0 = v.translation_mm[0], t1 = v.translation_mm[1], t2 = v.translation_mm[2];
    const double focal = v.focal_mm, kappa1 = v.kappa1;
    const double fx = v.px_per_mm_x, fy = v.px_per_mm_y, cx = v.cx_px, cy = v.cy_px;
    // Eigen's packet math (no errno branch in its square root) keeps this loop in
    // vector registers.
    using Lanes = Eigen::Array<double, kLanes, 1>;
    for (size_t block = 0; block < padded; block += kLanes) {
      const Eigen::Map<const Lanes> xs(X + block), ys(Y + block), zs(Z + block);
      // The weight cos^2 = (n.d)^2 / |d|^2 with the cosine test n.d >= min_cos |d| as
      // n.d >= 0 and (n.d)^2 >= min_cos^2 |d|^2: one division, no square root; -1 where
      // the test fails.
      const Lanes dx = ox - xs, dy = oy - ys, dz = oz - zs;
      const Lanes dot = nx * dx + ny * dy + nz * dz, d2 = dx * dx + dy * dy + dz * dz;
      Eigen::Map<Lanes>(weightv + block) =
          (dot >= 0.0 && dot * dot >= min_cos2 * d2).select(dot * dot / d2, Lanes::Constant(-1.0));
      const Lanes xc = r0 * xs + r1 * ys + r2 * zs + t0;
      const Lanes yc = r3 * xs + r4 * ys + r5 * zs + t1;
      const Lanes zc = r6 * xs + r7 * ys + r8 * zs + t2;
      Eigen::Map<Lanes>(czv + block) = zc;
      // FastView::Project without its branches: z <= 0 and |x| > 0.05 are redone
      // texel by texel below.
      const Lanes scale = focal / zc;
      const Lanes xu = xc * scale, yu = yc * scale;
      const Lanes x = kappa1 * (xu * xu + yu * yu);
      Eigen::Map<Lanes>(dv + block) = x;
      // One Newton step after the series (FastView::DistortionFactor takes two): its
      // relative error is below 3|x| (4e-5)^2 < 3e-10 for |x| <= 0.05, 1e-7 px at the
      // paper rig's image corners.
      Lanes lambda = 1.0 + x * (-1.0 + x * (3.0 + x * (-12.0 + x * (55.0 - 273.0 * x))));
      const Lanes xl2 = x * lambda * lambda;
      lambda -= (xl2 * lambda + lambda - 1.0) / (3.0 * xl2 + 1.0);
      Eigen::Map<Lanes>(pxv + block) = xu * lambda * fx + cx;
      Eigen::Map<Lanes>(pyv + block) = yu * lambda * fy + cy;
    }
    const int w = v.width, h = v.height;
    for (size_t k = 0; k < count; ++k) {
      const double weight = weightv[k];
      if (!(weight >= 0.0)) continue;
      const double zc = czv[k];
      if (!(zc > 0.0)) continue;
      double x = pxv[k], y = pyv[k];
      if (!(std::abs(dv[k]) <= 0.05)) {
        const double xc = r0 * X[k] + r1 * Y[k] + r2 * Z[k] + t0;
        const double yc = r3 * X[k] + r4 * Y[k] + r5 * Z[k] + t1;
        v.Project(xc, yc, zc, &x, &y);
      }
      if (!(x >= 0 && y >= 0 && x <= w - 1 && y <= h - 1)) continue;
      AddSample(v, x, y, zc, weight, options, &scratch->s0[k], &scratch->s1[k], &scratch->s2[k],
                &scratch->wsum[k]);
    }
  }
}

// Sets *out to the views that may paint some point of the face `f` (unit normal n).
// A view is left out only when, with a margin for rounding, no point of the triangle
// can pass one of Shade's tests for it: the cosine, in front of the camera, inside the
// image, the depth test. Shading the face's points with the rest sums the same terms
// in the same order, so the colours are those of shading with every view.
void CandidateViews(const io::Mesh& mesh, const Eigen::Vector3i& f, const Eigen::Vector3d& n,
                    const std::vector<ShadingView>& views, const TextureOptions& options,
                    std::vector<int>* out) {
  out->clear();
  const Eigen::Vector3d corner[3] = {mesh.vertices[f[0]].cast<double>(),
                                     mesh.vertices[f[1]].cast<double>(),
                                     mesh.vertices[f[2]].cast<double>()};
  const double e01 = (corner[1] - corner[0]).norm(), e12 = (corner[2] - corner[1]).norm(),
               e20 = (corner[0] - corner[2]).norm();
  // Farthest any point of the triangle is from each corner.
  const double reach[3] = {std::max(e01, e20), std::max(e01, e12), std::max(e12, e20)};
  for (size_t i = 0; i < views.size(); ++i) {
    const ShadingView& v = views[i];
    // Cosine: n.(centre - p) is linear in p (largest at a corner) and |centre - p| is at
    // least |centre - corner| - reach(corner) for every corner.
    double d_max = -std::numeric_limits<double>::infinity(), dist_min = 0.0, dist_max = 0.0;
    for (int m = 0; m < 3; ++m) {
      const Eigen::Vector3d to_cam = v.centre - corner[m];
      const double dist = to_cam.norm();
      d_max = std::max(d_max, n.dot(to_cam));
      dist_min = std::max(dist_min, dist - reach[m]);
      dist_max = std::max(dist_max, dist);
    }
    if (d_max + 1e-9 * (dist_max + 1.0) < options.min_cos_angle * dist_min) continue;
    // Camera z is linear in p too.
    const Eigen::Vector3d* c[3] = {&v.vertex_camera[f[0]], &v.vertex_camera[f[1]],
                                   &v.vertex_camera[f[2]]};
    const double z_min = std::min({c[0]->z(), c[1]->z(), c[2]->z()});
    const double z_max = std::max({c[0]->z(), c[1]->z(), c[2]->z()});
    const double z_slack = 1e-9 * (std::abs(z_max) + std::abs(z_min) + 1.0);
    if (z_max < -z_slack) continue;  // behind the camera everywhere
    if (!(z_min > z_slack)) {
      out->push_back(int(i));  // straddles the camera plane: no pixel bounds
      continue;
    }
    // Pixel bounds: perspective maps the triangle onto the triangle of its corners'
    // undistorted sensor points; distortion scales each point by rd/ru, which is
    // monotonic in ru (while kappa1 < 0 stays in range), so it lies between its values
    // at the nearest and farthest radius of the undistorted box.
    const FastView& pr = v.fast;
    double ux0 = std::numeric_limits<double>::infinity(), ux1 = -ux0, uy0 = ux0, uy1 = -ux0;
    for (int m = 0; m < 3; ++m) {
      const double xu = pr.focal_mm * c[m]->x() / c[m]->z();
      const double yu = pr.focal_mm * c[m]->y() / c[m]->z();
      ux0 = std::min(ux0, xu), ux1 = std::max(ux1, xu);
      uy0 = std::min(uy0, yu), uy1 = std::max(uy1, yu);
    }
    const double nx = ux0 > 0 ? ux0 : (ux1 < 0 ? -ux1 : 0.0);
    const double ny = uy0 > 0 ? uy0 : (uy1 < 0 ? -uy1 : 0.0);
    const double r2_near = nx * nx + ny * ny;
    const double r2_far = std::max(ux0 * ux0, ux1 * ux1) + std::max(uy0 * uy0, uy1 * uy1);
    double lambda_lo = 1.0, lambda_hi = 1.0;
    if (pr.kappa1 != 0.0) {
      // kappa1 < 0: Ru_max = 2 / (3 sqrt(-3 kappa1)), Ru_max^2 = -4 / (27 kappa1).
      if (pr.kappa1 < 0 && !(r2_far < -4.0 / (27.0 * pr.kappa1) * (1.0 - 1e-6))) {
        out->push_back(int(i));  // beyond the radius where the model folds back
        continue;
      }
      const double l_near = pr.DistortionFactor(r2_near), l_far = pr.DistortionFactor(r2_far);
      lambda_lo = std::min(l_near, l_far) * (1.0 - 1e-9);
      lambda_hi = std::max(l_near, l_far) * (1.0 + 1e-9);
    }
    const double sx_px = pr.px_per_mm_x, sy_px = pr.px_per_mm_y, slack_px = 1e-6;
    const double px0 = std::min(ux0 * lambda_lo, ux0 * lambda_hi) * sx_px + pr.cx_px - slack_px;
    const double px1 = std::max(ux1 * lambda_lo, ux1 * lambda_hi) * sx_px + pr.cx_px + slack_px;
    const double py0 = std::min(uy0 * lambda_lo, uy0 * lambda_hi) * sy_px + pr.cy_px - slack_px;
    const double py1 = std::max(uy1 * lambda_lo, uy1 * lambda_hi) * sy_px + pr.cy_px + slack_px;
    const int w = v.bgr.cols, h = v.bgr.rows;
    if (px1 < 0 || py1 < 0 || px0 > w - 1 || py0 > h - 1) continue;  // outside the image
    // Depth test: a point passes where its z is within the tolerance of the z-buffer
    // at its rounded pixel; no point of the face is nearer than z_min.
    const int xi0 = int(std::lround(std::max(px0, 0.0)));
    const int xi1 = int(std::lround(std::min(px1, double(w - 1))));
    const int yi0 = int(std::lround(std::max(py0, 0.0)));
    const int yi1 = int(std::lround(std::min(py1, double(h - 1))));
    const double z_needed = z_min - z_slack - options.depth_tolerance_mm;
    bool visible = false;
    for (int y = yi0; y <= yi1 && !visible; ++y) {
      const float* row = v.zbuffer.data() + size_t(y) * w;
      for (int x = xi0; x <= xi1; ++x) {
        if (double(row[x]) >= z_needed) {
          visible = true;
          break;
        }
      }
    }
    if (visible) out->push_back(int(i));
  }
}

Eigen::Vector3d FaceNormal(const io::Mesh& mesh, const Eigen::Vector3i& f) {
  const Eigen::Vector3d a = mesh.vertices[f[0]].cast<double>();
  return (mesh.vertices[f[1]].cast<double>() - a).cross(mesh.vertices[f[2]].cast<double>() - a);
}

}  // namespace

void TextureOptions::Check() const {
  core::Require(std::isfinite(depth_tolerance_mm) && depth_tolerance_mm > 0,
                "texture: depth_tolerance_mm", "must be a positive number of mm");
  core::Require(std::isfinite(min_cos_angle) && min_cos_angle >= 0 && min_cos_angle < 1,
                "texture: min_cos_angle", "must be in [0, 1)");
  core::Require(atlas_cell_px >= 4 && atlas_cell_px <= 256, "texture: atlas_cell_px",
                "must be in [4, 256] texels");
}

void CheckTextureView(const TextureView& view) {
  const std::string where = view.where.empty() ? "image of camera " + view.camera.id : view.where;
  view.camera.Check(where + ": camera");
  core::Require(view.image.type() == CV_8UC1 || view.image.type() == CV_8UC3, where,
                "must be an 8-bit gray or BGR image");
  core::Require(
      view.image.cols == view.camera.width_px && view.image.rows == view.camera.height_px, where,
      "image is " + std::to_string(view.image.cols) + "x" + std::to_string(view.image.rows) +
          " but camera " + view.camera.id + " is " + std::to_string(view.camera.width_px) + "x" +
          std::to_string(view.camera.height_px));
}

namespace {

// ColorVertices with the views prepared.
void ColourWith(const Prepared& prepared, const TextureOptions& options, io::Mesh* mesh) {
  std::vector<Eigen::Vector3d> normals(mesh->vertices.size(), Eigen::Vector3d::Zero());
  for (const auto& f : mesh->faces) {
    const Eigen::Vector3d n = FaceNormal(*mesh, f);  // area-weighted
    for (int m = 0; m < 3; ++m) normals[f[m]] += n;
  }
  mesh->colors.assign(mesh->vertices.size(), io::Color3u8(128, 128, 128));
  core::ParallelFor(
      0, int64_t(mesh->vertices.size()), options.num_threads, [&](int64_t b, int64_t e) {
        for (int64_t v = b; v < e; ++v) {
          Eigen::Vector3d bgr;
          const Eigen::Vector3d n = normals[v].normalized();
          const Eigen::Vector3d p = mesh->vertices[v].cast<double>();
          if (options.exhaustive ? Shade(p, n, prepared.views, options, &bgr)
                                 : ShadeFast(p, n, prepared.fast, nullptr, options, &bgr)) {
            mesh->colors[v] =
                io::Color3u8(uint8_t(std::lround(bgr[2])), uint8_t(std::lround(bgr[1])),
                             uint8_t(std::lround(bgr[0])));
          }
        }
      });
}

}  // namespace

GridAtlasLayout GridAtlasLayout::For(int64_t faces, int cell_px) {
  const int64_t cells = (faces + 1) / 2;
  GridAtlasLayout l;
  l.cell_px = cell_px;
  l.columns = std::max<int>(1, int(std::ceil(std::sqrt(double(cells)))));
  l.rows = std::max<int>(1, int((cells + l.columns - 1) / l.columns));
  return l;
}

Eigen::Vector2d GridAtlasLayout::CornerTexel(int64_t f, int m) const {
  const double lo = 0.5, hi = cell_px - 0.5;
  static constexpr int kHi[2][3][2] = {{{0, 0}, {1, 0}, {0, 1}}, {{1, 1}, {0, 1}, {1, 0}}};
  const int64_t cell = f / 2;
  const int* corner = kHi[f % 2][m];
  return {double(cell % columns) * cell_px + (corner[0] ? hi : lo),
          double(cell / columns) * cell_px + (corner[1] ? hi : lo)};
}

namespace {

// BuildTextureAtlas with the views prepared (for_atlas).
TexturedMesh AtlasWith(const Prepared& prepared_views, const TextureOptions& options,
                       const io::Mesh& mesh) {
  const std::vector<ShadingView>& prepared = prepared_views.views;
  const std::vector<FastView>& fast = prepared_views.fast;
  TexturedMesh out;
  out.mesh.vertices = mesh.vertices;
  out.mesh.faces = mesh.faces;
  const int64_t faces = int64_t(mesh.faces.size());
  const int s = options.atlas_cell_px;
  const GridAtlasLayout layout = GridAtlasLayout::For(faces, s);
  const int cols = layout.columns;
  const int64_t cells = (faces + 1) / 2;
  const int W = layout.width_px(), H = layout.height_px();
  out.atlas = cv::Mat(H, W, CV_8UC3, cv::Scalar(128, 128, 128));
  out.uv.resize(size_t(faces) * 3);
  // Corners of the two halves of a cell, in texel coordinates relative to the cell.
  const double lo = 0.5, hi = s - 0.5;
  const Eigen::Vector2d half_uv[2][3] = {{{lo, lo}, {hi, lo}, {lo, hi}},
                                         {{hi, hi}, {lo, hi}, {hi, lo}}};
  for (int64_t f = 0; f < faces; ++f) {
    for (int m = 0; m < 3; ++m) {
      const Eigen::Vector2d t = layout.CornerTexel(f, m);
      out.uv[size_t(f) * 3 + m] = Eigen::Vector2f(float(t.x() / W), float(1.0 - t.y() / H));
    }
  }
  // The texels of each half of a cell, with the barycentric weights of their centres.
  std::vector<Texel> texels[2];
  for (int ty = 0; ty < s; ++ty) {
    for (int tx = 0; tx < s; ++tx) {
      const int half = tx + ty < s - 1 ? 0 : 1;
      const Eigen::Vector2d* c = half_uv[half];
      const Eigen::Vector2d p(tx + 0.5, ty + 0.5);
      const double area =
          (c[1] - c[0]).x() * (c[2] - c[0]).y() - (c[2] - c[0]).x() * (c[1] - c[0]).y();
      double w1 = ((p - c[0]).x() * (c[2] - c[0]).y() - (c[2] - c[0]).x() * (p - c[0]).y()) / area;
      double w2 = ((c[1] - c[0]).x() * (p - c[0]).y() - (p - c[0]).x() * (c[1] - c[0]).y()) / area;
      w1 = std::clamp(w1, 0.0, 1.0);
      w2 = std::clamp(w2, 0.0, 1.0 - w1);
      texels[half].push_back({tx, ty, w1, w2});
    }
  }
  core::ParallelFor(0, cells, options.num_threads, [&](int64_t b, int64_t e) {
    std::vector<int> candidates;
    FaceScratch scratch;
    for (int64_t cell = b; cell < e; ++cell) {
      const int x0 = int(cell % cols) * s, y0 = int(cell / cols) * s;
      for (int half = 0; half < 2; ++half) {
        const int64_t f = cell * 2 + half;
        if (f >= faces) break;
        const Eigen::Vector3i& face = mesh.faces[f];
        const Eigen::Vector3d normal = FaceNormal(mesh, face).normalized();
        const auto put = [&](const Texel& t, const Eigen::Vector3d& bgr) {
          out.atlas.at<cv::Vec3b>(y0 + t.ty, x0 + t.tx) =
              cv::Vec3b(cv::saturate_cast<uint8_t>(bgr[0]), cv::saturate_cast<uint8_t>(bgr[1]),
                        cv::saturate_cast<uint8_t>(bgr[2]));
        };
        if (options.exhaustive) {
          const Eigen::Vector3d a = mesh.vertices[face[0]].cast<double>();
          for (const Texel& t : texels[half]) {
            const Eigen::Vector3d pt = a + t.w1 * (mesh.vertices[face[1]].cast<double>() - a) +
                                       t.w2 * (mesh.vertices[face[2]].cast<double>() - a);
            Eigen::Vector3d bgr;
            if (Shade(pt, normal, prepared, options, &bgr)) put(t, bgr);
          }
          continue;
        }
        CandidateViews(mesh, face, normal, prepared, options, &candidates);
        ShadeFace(mesh, face, normal, texels[half], fast, candidates, options, &scratch);
        for (size_t k = 0; k < texels[half].size(); ++k) {
          if (scratch.wsum[k] <= 0.0) continue;
          put(texels[half][k],
              Eigen::Vector3d(scratch.s0[k], scratch.s1[k], scratch.s2[k]) / scratch.wsum[k]);
        }
      }
    }
  });
  return out;
}

}  // namespace

void ColorVertices(io::Mesh* mesh, const std::vector<TextureView>& views,
                   const TextureOptions& options) {
  ColourWith(Prepare(*mesh, views, options, false), options, mesh);
}

TexturedMesh BuildTextureAtlas(const io::Mesh& mesh, const std::vector<TextureView>& views,
                               const TextureOptions& options) {
  return AtlasWith(Prepare(mesh, views, options, true), options, mesh);
}

std::optional<TexturedMesh> ColourAndAtlas(io::Mesh* mesh, const std::vector<TextureView>& views,
                                           const TextureOptions& options, bool atlas) {
  const Prepared prepared = Prepare(*mesh, views, options, atlas);
  ColourWith(prepared, options, mesh);
  if (!atlas) return std::nullopt;
  return AtlasWith(prepared, options, *mesh);
}

namespace {

// The OBJ text of EncodeTexturedObj.
std::string TexturedObjText(const TexturedMesh& t, const std::string& stem) {
  std::string obj;
  obj = "# dome textured mesh, world frame, mm\nmtllib " + stem + ".mtl\nusemtl dome\n";
  obj.reserve(t.mesh.vertices.size() * 40 + t.uv.size() * 30 + t.mesh.faces.size() * 40);
  // std::to_chars writes what printf's "%.6g" / "%.7g" / "%d" would, without parsing a
  // format and consulting the locale per number (most of the time of writing the OBJ).
  // A line is at most 2 + 3 x 32 characters; to_chars stops 8 short of the end, which
  // leaves room for the separator after it (and tells the compiler so).
  char line[160];
  char* const end = line + sizeof line - 8;
  const auto put = [&](char* at, auto value, auto... precision) {
    if constexpr (sizeof...(precision) > 0) {
      return std::to_chars(at, end, value, std::chars_format::general, precision...).ptr;
    } else {
      return std::to_chars(at, end, value).ptr;
    }
  };
  for (const auto& v : t.mesh.vertices) {
    char* at = line;
    *at++ = 'v';
    for (int k = 0; k < 3; ++k) {
      *at++ = ' ';
      at = put(at, double(v[k]), 6);
    }
    *at++ = '\n';
    obj.append(line, at);
  }
  for (const auto& uv : t.uv) {
    char* at = line;
    *at++ = 'v', *at++ = 't';
    for (int k = 0; k < 2; ++k) {
      *at++ = ' ';
      at = put(at, double(uv[k]), 7);
    }
    *at++ = '\n';
    obj.append(line, at);
  }
  for (size_t f = 0; f < t.mesh.faces.size(); ++f) {
    const auto& face = t.mesh.faces[f];
    char* at = line;
    *at++ = 'f';
    for (int k = 0; k < 3; ++k) {
      *at++ = ' ';
      at = put(at, face[k] + 1);
      *at++ = '/';
      at = put(at, 3 * f + size_t(k) + 1);
    }
    *at++ = '\n';
    obj.append(line, at);
  }
  return obj;
}

}  // namespace

TexturedObjFiles EncodeTexturedObj(const TexturedMesh& t, const std::string& stem,
                                   int num_threads) {
  TexturedObjFiles files;
  files.mtl = "newmtl dome\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nillum 1\nmap_Kd " + stem + ".png\n";
  // The PNG takes longer than the text (a 1072 x 1072 atlas about 70 ms, the text of a
  // 36,000-triangle mesh about 20 ms): the two side by side.
  core::ParallelFor(0, 2, num_threads, [&](int64_t b, int64_t e) {
    for (int64_t k = b; k < e; ++k) {
      if (k == 0)
        files.png = io::EncodePng(t.atlas);
      else
        files.obj = TexturedObjText(t, stem);
    }
  });
  return files;
}

void WriteTexturedObj(const std::filesystem::path& obj_path, const TexturedMesh& t) {
  const std::string stem = obj_path.stem().string();
  const auto dir = obj_path.parent_path();
  const TexturedObjFiles files = EncodeTexturedObj(t, stem);
  io::WriteFileAtomically(dir / (stem + ".png"), files.png);
  io::WriteFileAtomically(dir / (stem + ".mtl"), files.mtl);
  io::WriteFileAtomically(obj_path, files.obj);
}

std::vector<TextureView> LoadTextureViews(const take::Take& take, const std::string& instant) {
  std::vector<TextureView> views;
  for (const auto& rc : take.rig.cameras) {
    TextureView v;
    v.camera = rc.model;
    v.where = take.FramePath(instant, rc.model.id).string();
    v.image = io::ReadImage(v.where, io::ImageMode::kBgr8);
    views.push_back(std::move(v));
  }
  return views;
}

}  // namespace dome::mesh
