#include "silhouette/render.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <set>

#include "core/error.h"
#include "geometry/raster.h"

namespace dome::silhouette {

MeshRendering RenderMesh(const geometry::TsaiCamera& camera, const io::Mesh& mesh) {
  const int w = camera.width_px, h = camera.height_px;
  MeshRendering r;
  r.face = cv::Mat(h, w, CV_32SC1, cv::Scalar(-1));
  r.depth = cv::Mat(h, w, CV_32FC1, cv::Scalar(std::numeric_limits<float>::infinity()));
  r.weights = cv::Mat(h, w, CV_32FC3, cv::Scalar::all(0));
  // Per vertex: pixel x, y and camera z (z <= 0: not projected).
  std::vector<Eigen::Vector3d> proj(mesh.vertices.size());
  for (size_t v = 0; v < mesh.vertices.size(); ++v) {
    const Eigen::Vector3d c = camera.WorldToCamera(mesh.vertices[v].cast<double>());
    Eigen::Vector2d px;
    proj[v] = camera.ProjectCamera(c, &px) ? Eigen::Vector3d(px.x(), px.y(), c.z())
                                           : Eigen::Vector3d(0, 0, -1);
  }
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    const Eigen::Vector3i& face = mesh.faces[f];
    const Eigen::Vector3d& a = proj[face[0]];
    const Eigen::Vector3d& b = proj[face[1]];
    const Eigen::Vector3d& c = proj[face[2]];
    if (a.z() <= 0 || b.z() <= 0 || c.z() <= 0) continue;
    geometry::RasterizeTriangle(a.head<2>(), b.head<2>(), c.head<2>(), w, h, /*divide=*/true,
                                [&](int x, int y, double la, double lb, double lc) {
                                  // Perspective-correct: 1/z is linear in the image, and so are
                                  // attributes / z.
                                  const double qa = la / a.z(), qb = lb / b.z(), qc = lc / c.z();
                                  const double s = qa + qb + qc;
                                  const float z = float(1.0 / s);
                                  float& dz = r.depth.at<float>(y, x);
                                  if (!(z < dz)) return;
                                  dz = z;
                                  r.face.at<int>(y, x) = int(f);
                                  r.weights.at<cv::Vec3f>(y, x) =
                                      cv::Vec3f(float(qa / s), float(qb / s), float(qc / s));
                                });
  }
  return r;
}

cv::Mat RenderedMask(const MeshRendering& rendering) { return rendering.face >= 0; }

namespace {

// A BGR image, black where the rendering has no surface, else shade(face, weights).
template <typename Shade>
cv::Mat ShadeSurface(const MeshRendering& rendering, Shade&& shade) {
  cv::Mat out(rendering.face.size(), CV_8UC3, cv::Scalar::all(0));
  for (int y = 0; y < out.rows; ++y) {
    const int* fp = rendering.face.ptr<int>(y);
    const cv::Vec3f* wp = rendering.weights.ptr<cv::Vec3f>(y);
    cv::Vec3b* op = out.ptr<cv::Vec3b>(y);
    for (int x = 0; x < out.cols; ++x)
      if (fp[x] >= 0) op[x] = shade(fp[x], wp[x]);
  }
  return out;
}

}  // namespace

cv::Mat ShadeVertexColours(const MeshRendering& rendering, const io::Mesh& mesh) {
  core::Require(mesh.HasColors(), "ShadeVertexColours: mesh", "has no per-vertex colours");
  return ShadeSurface(rendering, [&](int face, const cv::Vec3f& w) {
    const Eigen::Vector3i& f = mesh.faces[face];
    cv::Vec3b bgr;
    for (int ch = 0; ch < 3; ++ch) {
      double v = 0.0;
      for (int k = 0; k < 3; ++k) v += w[k] * mesh.colors[f[k]][ch];
      bgr[2 - ch] = cv::saturate_cast<uint8_t>(v);  // RGB -> BGR
    }
    return bgr;
  });
}

cv::Mat ShadeAtlas(const MeshRendering& rendering, const std::vector<Eigen::Vector2f>& uv,
                   const cv::Mat& atlas) {
  core::Require(atlas.type() == CV_8UC3 && !atlas.empty(), "ShadeAtlas: atlas",
                "expected a BGR 8-bit image");
  const int aw = atlas.cols, ah = atlas.rows;
  return ShadeSurface(rendering, [&](int face, const cv::Vec3f& w) {
    const size_t base = 3 * size_t(face);
    core::Require(base + 2 < uv.size(), "ShadeAtlas: uv", "fewer than 3 coordinates per face");
    double u = 0.0, v = 0.0;
    for (int k = 0; k < 3; ++k) {
      u += w[k] * uv[base + k].x();
      v += w[k] * uv[base + k].y();
    }
    const double tx = std::clamp(u * aw - 0.5, 0.0, aw - 1.0);
    const double ty = std::clamp((1.0 - v) * ah - 0.5, 0.0, ah - 1.0);
    const int ix = std::min(int(tx), std::max(0, aw - 2));
    const int iy = std::min(int(ty), std::max(0, ah - 2));
    const int jx = std::min(ix + 1, aw - 1), jy = std::min(iy + 1, ah - 1);
    const double fx = tx - ix, fy = ty - iy;
    cv::Vec3b bgr;
    for (int ch = 0; ch < 3; ++ch) {
      const double top =
          (1 - fx) * atlas.at<cv::Vec3b>(iy, ix)[ch] + fx * atlas.at<cv::Vec3b>(iy, jx)[ch];
      const double bottom =
          (1 - fx) * atlas.at<cv::Vec3b>(jy, ix)[ch] + fx * atlas.at<cv::Vec3b>(jy, jx)[ch];
      bgr[ch] = cv::saturate_cast<uint8_t>((1 - fy) * top + fy * bottom);
    }
    return bgr;
  });
}

double MaskedPsnr(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
  core::Require(a.type() == b.type() && a.size() == b.size() && a.depth() == CV_8U,
                "MaskedPsnr: images", "expected two 8-bit images of one size and type");
  core::Require(mask.type() == CV_8UC1 && mask.size() == a.size(), "MaskedPsnr: mask",
                "expected an 8-bit mask of the images' size");
  const int channels = a.channels();
  double sum = 0.0;
  int64_t count = 0;
  for (int y = 0; y < a.rows; ++y) {
    const uint8_t* ap = a.ptr<uint8_t>(y);
    const uint8_t* bp = b.ptr<uint8_t>(y);
    const uint8_t* mp = mask.ptr<uint8_t>(y);
    for (int x = 0; x < a.cols; ++x) {
      if (mp[x] == 0) continue;
      for (int ch = 0; ch < channels; ++ch) {
        const double d = double(ap[x * channels + ch]) - bp[x * channels + ch];
        sum += d * d;
      }
      count += channels;
    }
  }
  if (count == 0) return std::numeric_limits<double>::quiet_NaN();
  if (sum == 0.0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(255.0 * 255.0 * double(count) / sum);
}

int MeshComponents(const io::Mesh& mesh) {
  std::vector<int> parent(mesh.vertices.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const auto& f : mesh.faces) {
    const int r0 = find(f[0]);
    parent[find(f[1])] = r0;
    parent[find(f[2])] = r0;
  }
  std::set<int> roots;
  for (const auto& f : mesh.faces) roots.insert(find(f[0]));
  return int(roots.size());
}

}  // namespace dome::silhouette
