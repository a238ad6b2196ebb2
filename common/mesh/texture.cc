#include "mesh/texture.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/parallel_for.h"
#include "io/file_util.h"
#include "io/image_io.h"

namespace dome::mesh {
namespace {

// One camera prepared for shading: colour image, z-buffer of the mesh, centre.
struct ShadingView {
  const geometry::TsaiCamera* camera = nullptr;
  cv::Mat bgr;                 // CV_8UC3
  std::vector<float> zbuffer;  // camera z of the nearest mesh surface per pixel, mm
  Eigen::Vector3d centre;
};

// Renders the mesh's camera depth into a z-buffer: vertices are projected exactly
// (with distortion), triangles filled in pixel space with z interpolated linearly.
std::vector<float> RenderZBuffer(const geometry::TsaiCamera& cam, const io::Mesh& mesh) {
  const int w = cam.width_px, h = cam.height_px;
  std::vector<float> zbuf(size_t(w) * h, std::numeric_limits<float>::infinity());
  std::vector<Eigen::Vector3d> proj(mesh.vertices.size());
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    const Eigen::Vector3d c = cam.WorldToCamera(mesh.vertices[v].cast<double>());
    Eigen::Vector2d px;
    proj[v] = cam.ProjectCamera(c, &px) ? Eigen::Vector3d(px.x(), px.y(), c.z())
                                        : Eigen::Vector3d(0, 0, -1);
  }
  for (const auto& f : mesh.faces) {
    const Eigen::Vector3d& a = proj[f[0]];
    const Eigen::Vector3d& b = proj[f[1]];
    const Eigen::Vector3d& c = proj[f[2]];
    if (a.z() <= 0 || b.z() <= 0 || c.z() <= 0) continue;
    const int x0 = std::max(0, int(std::ceil(std::min({a.x(), b.x(), c.x()}))));
    const int x1 = std::min(w - 1, int(std::floor(std::max({a.x(), b.x(), c.x()}))));
    const int y0 = std::max(0, int(std::ceil(std::min({a.y(), b.y(), c.y()}))));
    const int y1 = std::min(h - 1, int(std::floor(std::max({a.y(), b.y(), c.y()}))));
    const double area = (b.x() - a.x()) * (c.y() - a.y()) - (c.x() - a.x()) * (b.y() - a.y());
    if (x0 > x1 || y0 > y1 || std::abs(area) < 1e-12) continue;
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const double wa = ((b.x() - x) * (c.y() - y) - (c.x() - x) * (b.y() - y)) / area;
        const double wb = ((c.x() - x) * (a.y() - y) - (a.x() - x) * (c.y() - y)) / area;
        const double wc = 1.0 - wa - wb;
        if (wa < -1e-9 || wb < -1e-9 || wc < -1e-9) continue;
        const float z = float(wa * a.z() + wb * b.z() + wc * c.z());
        float& dst = zbuf[size_t(y) * w + x];
        dst = std::min(dst, z);
      }
    }
  }
  return zbuf;
}

std::vector<ShadingView> PrepareViews(const io::Mesh& mesh, const std::vector<TextureView>& views,
                                      const TextureOptions& options) {
  std::vector<ShadingView> out(views.size());
  core::ParallelFor(0, int64_t(views.size()), options.num_threads, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      out[i].camera = &views[i].camera;
      if (views[i].image.channels() == 1) {
        cv::cvtColor(views[i].image, out[i].bgr, cv::COLOR_GRAY2BGR);
      } else {
        out[i].bgr = views[i].image;
      }
      out[i].zbuffer = RenderZBuffer(views[i].camera, mesh);
      out[i].centre = views[i].camera.CentreWorld();
    }
  });
  return out;
}

// Weighted mean colour (BGR, 0..255) of point p with unit normal n; false if unseen.
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

void ColorVertices(io::Mesh* mesh, const std::vector<TextureView>& views,
                   const TextureOptions& options) {
  options.Check();
  for (const auto& v : views) CheckTextureView(v);
  const auto prepared = PrepareViews(*mesh, views, options);
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
          if (Shade(mesh->vertices[v].cast<double>(), n, prepared, options, &bgr)) {
            mesh->colors[v] =
                io::Color3u8(uint8_t(std::lround(bgr[2])), uint8_t(std::lround(bgr[1])),
                             uint8_t(std::lround(bgr[0])));
          }
        }
      });
}

TexturedMesh BuildTextureAtlas(const io::Mesh& mesh, const std::vector<TextureView>& views,
                               const TextureOptions& options) {
  options.Check();
  for (const auto& v : views) CheckTextureView(v);
  const auto prepared = PrepareViews(mesh, views, options);
  TexturedMesh out;
  out.mesh.vertices = mesh.vertices;
  out.mesh.faces = mesh.faces;
  const int64_t faces = int64_t(mesh.faces.size());
  const int s = options.atlas_cell_px;
  const int64_t cells = (faces + 1) / 2;
  const int cols = std::max<int>(1, int(std::ceil(std::sqrt(double(cells)))));
  const int rows = std::max<int>(1, int((cells + cols - 1) / cols));
  const int W = cols * s, H = rows * s;
  out.atlas = cv::Mat(H, W, CV_8UC3, cv::Scalar(128, 128, 128));
  out.uv.resize(size_t(faces) * 3);
  // Corners of the two halves of a cell, in texel coordinates relative to the cell.
  const double lo = 0.5, hi = s - 0.5;
  const Eigen::Vector2d half_uv[2][3] = {{{lo, lo}, {hi, lo}, {lo, hi}},
                                         {{hi, hi}, {lo, hi}, {hi, lo}}};
  for (int64_t f = 0; f < faces; ++f) {
    const int64_t cell = f / 2;
    const double x0 = double(cell % cols) * s, y0 = double(cell / cols) * s;
    for (int m = 0; m < 3; ++m) {
      const Eigen::Vector2d t = half_uv[f % 2][m] + Eigen::Vector2d(x0, y0);
      out.uv[size_t(f) * 3 + m] = Eigen::Vector2f(float(t.x() / W), float(1.0 - t.y() / H));
    }
  }
  core::ParallelFor(0, cells, options.num_threads, [&](int64_t b, int64_t e) {
    for (int64_t cell = b; cell < e; ++cell) {
      const int x0 = int(cell % cols) * s, y0 = int(cell / cols) * s;
      for (int ty = 0; ty < s; ++ty) {
        for (int tx = 0; tx < s; ++tx) {
          const int half = tx + ty < s - 1 ? 0 : 1;
          const int64_t f = cell * 2 + half;
          if (f >= faces) continue;
          const Eigen::Vector2d* c = half_uv[half];
          const Eigen::Vector2d p(tx + 0.5, ty + 0.5);
          const double area =
              (c[1] - c[0]).x() * (c[2] - c[0]).y() - (c[2] - c[0]).x() * (c[1] - c[0]).y();
          double w1 =
              ((p - c[0]).x() * (c[2] - c[0]).y() - (c[2] - c[0]).x() * (p - c[0]).y()) / area;
          double w2 =
              ((c[1] - c[0]).x() * (p - c[0]).y() - (p - c[0]).x() * (c[1] - c[0]).y()) / area;
          w1 = std::clamp(w1, 0.0, 1.0);
          w2 = std::clamp(w2, 0.0, 1.0 - w1);
          const auto& face = mesh.faces[f];
          const Eigen::Vector3d a = mesh.vertices[face[0]].cast<double>();
          const Eigen::Vector3d pt = a + w1 * (mesh.vertices[face[1]].cast<double>() - a) +
                                     w2 * (mesh.vertices[face[2]].cast<double>() - a);
          Eigen::Vector3d bgr;
          if (Shade(pt, FaceNormal(mesh, face).normalized(), prepared, options, &bgr)) {
            out.atlas.at<cv::Vec3b>(y0 + ty, x0 + tx) =
                cv::Vec3b(cv::saturate_cast<uint8_t>(bgr[0]), cv::saturate_cast<uint8_t>(bgr[1]),
                          cv::saturate_cast<uint8_t>(bgr[2]));
          }
        }
      }
    }
  });
  return out;
}

void WriteTexturedObj(const std::filesystem::path& obj_path, const TexturedMesh& t) {
  const std::string stem = obj_path.stem().string();
  const auto dir = obj_path.parent_path();
  io::WriteImage(dir / (stem + ".png"), t.atlas);
  io::WriteFileAtomically(
      dir / (stem + ".mtl"),
      "newmtl dome\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nillum 1\nmap_Kd " + stem + ".png\n");
  std::string obj = "# dome textured mesh, world frame, mm\nmtllib " + stem + ".mtl\nusemtl dome\n";
  obj.reserve(t.mesh.vertices.size() * 40 + t.uv.size() * 30 + t.mesh.faces.size() * 40);
  char buf[128];
  for (const auto& v : t.mesh.vertices) {
    std::snprintf(buf, sizeof buf, "v %.6g %.6g %.6g\n", v.x(), v.y(), v.z());
    obj += buf;
  }
  for (const auto& uv : t.uv) {
    std::snprintf(buf, sizeof buf, "vt %.7g %.7g\n", uv.x(), uv.y());
    obj += buf;
  }
  for (size_t f = 0; f < t.mesh.faces.size(); ++f) {
    const auto& face = t.mesh.faces[f];
    std::snprintf(buf, sizeof buf, "f %d/%zu %d/%zu %d/%zu\n", face[0] + 1, 3 * f + 1, face[1] + 1,
                  3 * f + 2, face[2] + 1, 3 * f + 3);
    obj += buf;
  }
  io::WriteFileAtomically(obj_path, obj);
}

}  // namespace dome::mesh
