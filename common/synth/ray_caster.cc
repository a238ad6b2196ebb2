#include "synth/ray_caster.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <limits>
#include <mutex>
#include <string>

#include "core/error.h"

namespace dome::synth {
namespace {

void ErrorCallback(void*, RTCError code, const char* message) {
  DOME_CHECK(code == RTC_ERROR_NONE, std::string("Embree: ") + (message ? message : "error"));
}

// One Embree device for the process; builds run on the calling thread only.
RTCDevice Device() {
  static RTCDevice device = [] {
    RTCDevice d = rtcNewDevice("threads=1");
    DOME_CHECK(d != nullptr, "cannot create the Embree device");
    rtcSetDeviceErrorFunction(d, ErrorCallback, nullptr);
    return d;
  }();
  return device;
}

}  // namespace

struct RayCaster::Impl {
  RTCScene scene = nullptr;
  ~Impl() {
    if (scene != nullptr) rtcReleaseScene(scene);
  }
};

RayCaster::RayCaster(const SceneMesh& mesh) : mesh_(&mesh), impl_(std::make_unique<Impl>()) {
  // Embree's builder state is per scene; serialize builds to keep them single-threaded.
  static std::mutex build_mutex;
  std::lock_guard<std::mutex> lock(build_mutex);
  RTCDevice device = Device();
  impl_->scene = rtcNewScene(device);
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
  if (!mesh.faces.empty()) {
    RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vertices = static_cast<float*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                3 * sizeof(float), mesh.vertices.size()));
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
      vertices[3 * i + 0] = mesh.vertices[i].x();
      vertices[3 * i + 1] = mesh.vertices[i].y();
      vertices[3 * i + 2] = mesh.vertices[i].z();
    }
    auto* indices = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(unsigned), mesh.faces.size()));
    for (size_t i = 0; i < mesh.faces.size(); ++i) {
      for (int k = 0; k < 3; ++k) indices[3 * i + k] = static_cast<unsigned>(mesh.faces[i][k]);
    }
    rtcSetGeometryBuildQuality(geometry, RTC_BUILD_QUALITY_HIGH);
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(impl_->scene, geometry);
    rtcReleaseGeometry(geometry);
  }
  rtcCommitScene(impl_->scene);
}

RayCaster::~RayCaster() = default;

bool RayCaster::Intersect(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction,
                          RayHit* hit, float t_min) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh;
  rh.ray.org_x = origin.x();
  rh.ray.org_y = origin.y();
  rh.ray.org_z = origin.z();
  rh.ray.dir_x = direction.x();
  rh.ray.dir_y = direction.y();
  rh.ray.dir_z = direction.z();
  rh.ray.tnear = t_min;
  rh.ray.tfar = std::numeric_limits<float>::infinity();
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.time = 0.0f;
  rh.ray.flags = 0;
  rh.ray.id = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &context, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
  hit->t = rh.ray.tfar;
  hit->face = rh.hit.primID;
  hit->u = rh.hit.u;
  hit->v = rh.hit.v;
  return true;
}

void RayCaster::IntersectMany(const Eigen::Vector3f& origin, const Eigen::Vector3f* directions,
                              int count, RayHit* hits) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  alignas(64) RTCRayHit16 rh;
  alignas(64) int valid[16];
  for (int start = 0; start < count; start += 16) {
    const int n = std::min(16, count - start);
    for (int i = 0; i < 16; ++i) {
      const bool on = i < n;
      valid[i] = on ? -1 : 0;
      const Eigen::Vector3f& d = directions[start + (on ? i : 0)];
      rh.ray.org_x[i] = origin.x();
      rh.ray.org_y[i] = origin.y();
      rh.ray.org_z[i] = origin.z();
      rh.ray.dir_x[i] = d.x();
      rh.ray.dir_y[i] = d.y();
      rh.ray.dir_z[i] = d.z();
      rh.ray.tnear[i] = 0.0f;
      rh.ray.tfar[i] = std::numeric_limits<float>::infinity();
      rh.ray.mask[i] = 0xFFFFFFFFu;
      rh.ray.time[i] = 0.0f;
      rh.ray.flags[i] = 0;
      rh.ray.id[i] = static_cast<unsigned>(i);
      rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
      rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect16(valid, impl_->scene, &context, &rh);
    for (int i = 0; i < n; ++i) {
      RayHit& hit = hits[start + i];
      if (rh.hit.geomID[i] == RTC_INVALID_GEOMETRY_ID) {
        hit = RayHit();
        hit.face = RayHit::kNoFace;
        continue;
      }
      hit.t = rh.ray.tfar[i];
      hit.face = rh.hit.primID[i];
      hit.u = rh.hit.u[i];
      hit.v = rh.hit.v[i];
    }
  }
}

}  // namespace dome::synth
