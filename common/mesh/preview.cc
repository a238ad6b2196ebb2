#include "mesh/preview.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/error.h"
#include "core/parallel_for.h"

namespace dome::mesh {
namespace {

void ErrorCallback(void*, RTCError code, const char* message) {
  DOME_CHECK(code == RTC_ERROR_NONE, std::string("Embree: ") + (message ? message : "error"));
}

// The mesh as an Embree scene (device and scene released with it).
class Scene {
 public:
  explicit Scene(const io::Mesh& mesh) {
    device_ = rtcNewDevice("threads=1");
    DOME_CHECK(device_ != nullptr, "cannot create the Embree device");
    rtcSetDeviceErrorFunction(device_, ErrorCallback, nullptr);
    scene_ = rtcNewScene(device_);
    rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST);
    if (!mesh.faces.empty()) {
      RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
      auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0,
                                                            RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                            mesh.vertices.size()));
      for (size_t n = 0; n < mesh.vertices.size(); ++n) {
        for (int a = 0; a < 3; ++a) v[3 * n + a] = mesh.vertices[n][a];
      }
      auto* f = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
          g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), mesh.faces.size()));
      for (size_t n = 0; n < mesh.faces.size(); ++n) {
        for (int a = 0; a < 3; ++a) f[3 * n + a] = unsigned(mesh.faces[n][a]);
      }
      rtcCommitGeometry(g);
      rtcAttachGeometry(scene_, g);
      rtcReleaseGeometry(g);
    }
    rtcCommitScene(scene_);
  }
  ~Scene() {
    rtcReleaseScene(scene_);
    rtcReleaseDevice(device_);
  }
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;

  // Closest hit of the ray origin + t dir, t > 0; false on a miss.
  bool Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, RTCRayHit* rh) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    rh->ray.org_x = float(origin.x());
    rh->ray.org_y = float(origin.y());
    rh->ray.org_z = float(origin.z());
    rh->ray.dir_x = float(dir.x());
    rh->ray.dir_y = float(dir.y());
    rh->ray.dir_z = float(dir.z());
    rh->ray.tnear = 0.0f;
    rh->ray.tfar = std::numeric_limits<float>::infinity();
    rh->ray.mask = 0xffffffffu;
    rh->ray.flags = 0;
    rh->ray.time = 0.0f;
    rh->hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_, &context, rh);
    return rh->hit.geomID != RTC_INVALID_GEOMETRY_ID;
  }

 private:
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
};

void CheckInputs(const io::Mesh& mesh, const geometry::TsaiCamera& camera) {
  const std::string bad = mesh.Inconsistency();
  core::Require(bad.empty(), "preview: mesh", bad);
  camera.Check("preview: camera " + camera.id);
}

// Calls shade(x, y, hit, unit ray direction) for every pixel whose ray hits the mesh.
template <typename Fn>
void CastPixels(const io::Mesh& mesh, const geometry::TsaiCamera& camera, int num_threads,
                const Fn& shade) {
  const Scene scene(mesh);
  const Eigen::Vector3d origin = camera.CentreWorld();
  core::ParallelFor(0, camera.height_px, num_threads, [&](int64_t y0, int64_t y1) {
    RTCRayHit rh;
    for (int64_t y = y0; y < y1; ++y) {
      for (int x = 0; x < camera.width_px; ++x) {
        const Eigen::Vector3d dir = camera.BackProject(Eigen::Vector2d(x, double(y))).normalized();
        if (scene.Intersect(origin, dir, &rh)) shade(x, int(y), rh, dir);
      }
    }
  });
}

}  // namespace

cv::Mat RenderPreview(const io::Mesh& mesh, const geometry::TsaiCamera& camera,
                      const PreviewOptions& options) {
  CheckInputs(mesh, camera);
  cv::Mat image(camera.height_px, camera.width_px, CV_8UC3, cv::Scalar(0, 0, 0));
  const bool colors = options.use_colors && mesh.HasColors();
  CastPixels(mesh, camera, options.num_threads,
             [&](int x, int y, const RTCRayHit& rh, const Eigen::Vector3d& dir) {
               cv::Vec3b& px = image.at<cv::Vec3b>(y, x);
               if (colors) {
                 const Eigen::Vector3i& f = mesh.faces[rh.hit.primID];
                 const float u = rh.hit.u, v = rh.hit.v;
                 const Eigen::Vector3f c = (1 - u - v) * mesh.colors[f[0]].cast<float>() +
                                           u * mesh.colors[f[1]].cast<float>() +
                                           v * mesh.colors[f[2]].cast<float>();
                 for (int a = 0; a < 3; ++a) {
                   px[2 - a] = cv::saturate_cast<uchar>(std::lround(c[a]));  // RGB -> BGR
                 }
                 return;
               }
               const Eigen::Vector3d ng(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
               const double n = ng.norm();
               const double cosine = n > 0 ? std::abs(ng.dot(dir)) / n : 0.0;
               const uchar grey = cv::saturate_cast<uchar>(std::lround(40.0 + 215.0 * cosine));
               px = cv::Vec3b(grey, grey, grey);
             });
  return image;
}

cv::Mat RenderDepth(const io::Mesh& mesh, const geometry::TsaiCamera& camera, int num_threads) {
  CheckInputs(mesh, camera);
  cv::Mat depth(camera.height_px, camera.width_px, CV_32FC1, cv::Scalar(0));
  const Eigen::Vector3d origin = camera.CentreWorld();
  CastPixels(mesh, camera, num_threads,
             [&](int x, int y, const RTCRayHit& rh, const Eigen::Vector3d& dir) {
               const Eigen::Vector3d hit = origin + double(rh.ray.tfar) * dir;
               depth.at<float>(y, x) = float(camera.WorldToCamera(hit).z());
             });
  return depth;
}

}  // namespace dome::mesh
