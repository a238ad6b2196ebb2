#include "synth/dome_rig.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <tuple>

#include "core/error.h"
#include "synth/noise.h"

namespace dome::synth {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

constexpr double kDeg = M_PI / 180.0;
constexpr double kSensorWidthMm = 6.4;  // 1/2" CCD
constexpr double kSensorHeightMm = 4.8;
constexpr uint64_t kCameraStream = 0xd0e5ca3e7a5ULL;
constexpr int kMaxFrequency = 8;

struct Geodesic {
  std::vector<Vector3d> vertices;  // unit vectors
  std::set<std::pair<int, int>> edges;
};

// Class-I geodesic sphere: the icosahedron with vertex 0 rotated to +z, every face
// cut into frequency^2 triangles, new vertices pushed out to the unit sphere.
Geodesic MakeGeodesic(int frequency) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vector3d> ico = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                               {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                               {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  const int faces[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                            {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                            {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                            {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (auto& v : ico) v.normalize();
  const Eigen::Quaterniond up = Eigen::Quaterniond::FromTwoVectors(ico[0], Vector3d::UnitZ());
  for (auto& v : ico) v = up * v;

  Geodesic g;
  std::map<std::tuple<long, long, long>, int> index;
  auto vertex = [&](const Vector3d& p) {
    const Vector3d u = p.normalized();
    const auto key = std::make_tuple(std::lround(u.x() * 1e7), std::lround(u.y() * 1e7),
                                     std::lround(u.z() * 1e7));
    const auto it = index.find(key);
    if (it != index.end()) return it->second;
    const int id = static_cast<int>(g.vertices.size());
    g.vertices.push_back(u);
    index.emplace(key, id);
    return id;
  };
  auto edge = [&](int a, int b) { g.edges.insert({std::min(a, b), std::max(a, b)}); };
  const int n = frequency;
  for (const auto& f : faces) {
    const Vector3d a = ico[f[0]], b = ico[f[1]], c = ico[f[2]];
    // Point (i, j) of the face's lattice: a + (b - a) i / n + (c - a) j / n, i + j <= n.
    auto at = [&](int i, int j) { return vertex(a + (b - a) * i / n + (c - a) * j / n); };
    for (int i = 0; i < n; ++i) {
      for (int j = 0; i + j < n; ++j) {
        const int p = at(i, j), q = at(i + 1, j), r = at(i, j + 1);
        edge(p, q);
        edge(q, r);
        edge(r, p);
      }
    }
  }
  return g;
}

double ElevationDeg(const Vector3d& u) { return std::asin(std::clamp(u.z(), -1.0, 1.0)) / kDeg; }
double AzimuthDeg(const Vector3d& u) {
  double a = std::atan2(u.y(), u.x()) / kDeg;
  if (a < 0) a += 360.0;
  return a;
}

// Vertices with elevation >= min, ordered top first then by azimuth.
std::vector<int> Upper(const Geodesic& g, double min_elevation_deg) {
  std::vector<int> ids;
  for (int i = 0; i < static_cast<int>(g.vertices.size()); ++i) {
    if (ElevationDeg(g.vertices[i]) >= min_elevation_deg - 1e-9) ids.push_back(i);
  }
  std::sort(ids.begin(), ids.end(), [&](int a, int b) {
    const long ea = std::lround(ElevationDeg(g.vertices[a]) * 1e6);
    const long eb = std::lround(ElevationDeg(g.vertices[b]) * 1e6);
    if (ea != eb) return ea > eb;
    const long aa = std::lround(AzimuthDeg(g.vertices[a]) * 1e6) % 360000000L;
    const long ab = std::lround(AzimuthDeg(g.vertices[b]) * 1e6) % 360000000L;
    if (aa != ab) return aa < ab;
    return a < b;
  });
  return ids;
}

std::string CameraId(int index, int count) {
  int digits = 2;
  for (int n = count - 1; n >= 100; n /= 10) ++digits;
  std::string number = std::to_string(index);
  if (static_cast<int>(number.size()) < digits) number.insert(0, digits - number.size(), '0');
  return "c" + number;
}

}  // namespace

int DomeRigOptions::MaxCameras() {
  return static_cast<int>(
      Upper(MakeGeodesic(kMaxFrequency), DomeRigOptions().min_elevation_deg).size());
}

void DomeRigOptions::Check() const {
  const int max_cameras = MaxCameras();
  core::Require(
      cameras >= 1 && cameras <= max_cameras, "--cameras",
      "expected 1.." + std::to_string(max_cameras) + " cameras, got " + std::to_string(cameras));
  core::Require(width_px >= 8 && width_px <= 4096, "--width",
                "expected an image width of 8..4096 pixels, got " + std::to_string(width_px));
  core::Require(height_px >= 8 && height_px <= 4096, "--height",
                "expected an image height of 8..4096 pixels, got " + std::to_string(height_px));
  DOME_CHECK(radius_mm > 0 && centre_height_mm + radius_mm > aim_mm.z(), "bad dome geometry");
}

geometry::TsaiSensor DigitizedSensor(int width_px, int height_px) {
  geometry::TsaiSensor sensor;
  sensor.ncx = 2.0 * width_px;
  sensor.nfx = width_px;
  sensor.dx_mm = kSensorWidthMm / (2.0 * width_px);
  sensor.dy_mm = 2.0 * kSensorHeightMm / (2.0 * height_px);
  return sensor;
}

std::vector<DomeCamera> MakeDomeRig(const DomeRigOptions& options) {
  options.Check();
  int frequency = 1;
  Geodesic g = MakeGeodesic(frequency);
  std::vector<int> upper = Upper(g, options.min_elevation_deg);
  while (static_cast<int>(upper.size()) < options.cameras && frequency < kMaxFrequency) {
    g = MakeGeodesic(++frequency);
    upper = Upper(g, options.min_elevation_deg);
  }
  DOME_CHECK(static_cast<int>(upper.size()) >= options.cameras, "Check() let too many cameras by");
  upper.resize(options.cameras);
  std::map<int, int> camera_of_vertex;
  for (int i = 0; i < options.cameras; ++i) camera_of_vertex[upper[i]] = i;

  const geometry::TsaiSensor sensor = DigitizedSensor(options.width_px, options.height_px);
  // Focal length giving a 90 deg horizontal field of view at the mean kappa1: the
  // image's edge (half the sensor width, distorted) undistorts to tan(45 deg) * f.
  const double kappa_mean = 1.5e-3;
  const double half_width = 0.5 * kSensorWidthMm;
  const double focal_nominal = half_width * (1.0 + kappa_mean * half_width * half_width);
  const Vector3d dome_centre(0, 0, options.centre_height_mm);

  std::vector<DomeCamera> cameras(options.cameras);
  for (int i = 0; i < options.cameras; ++i) {
    Rng rng(HashKey(kCameraStream, static_cast<uint64_t>(i)));
    const Vector3d& u = g.vertices[upper[i]];
    DomeCamera& cam = cameras[i];
    cam.geodesic_vertex = upper[i];
    cam.elevation_deg = ElevationDeg(u);
    cam.azimuth_deg = AzimuthDeg(u);
    geometry::TsaiCamera& m = cam.rig.model;
    m.id = CameraId(i, options.cameras);
    m.width_px = options.width_px;
    m.height_px = options.height_px;
    m.sensor = sensor;
    m.focal_mm = focal_nominal * rng.Uniform(0.97, 1.03);
    m.kappa1_per_mm2 = rng.Uniform(1.0e-3, 2.0e-3);
    m.cx_px = 0.5 * (options.width_px - 1) + rng.Normal(0.0, 3.0) * options.width_px / 320.0;
    m.cy_px = 0.5 * (options.height_px - 1) + rng.Normal(0.0, 3.0) * options.height_px / 245.0;
    m.sx = rng.Uniform(0.99, 1.01);

    const Vector3d centre = dome_centre + options.radius_mm * u;
    const Vector3d aim =
        options.aim_mm + Vector3d(rng.Uniform(-60, 60), rng.Uniform(-60, 60), rng.Uniform(-60, 60));
    const Vector3d z = (aim - centre).normalized();
    // Image y points down: towards world -z, or world -y when looking almost straight down.
    const Vector3d down = std::abs(z.z()) > 0.99 ? Vector3d(0, -1, 0) : Vector3d(0, 0, -1);
    Vector3d y = (down - down.dot(z) * z).normalized();
    Vector3d x = y.cross(z);
    const double roll = rng.Normal(0.0, 1.5) * kDeg;
    const Vector3d xr = std::cos(roll) * x + std::sin(roll) * y;
    const Vector3d yr = -std::sin(roll) * x + std::cos(roll) * y;
    Matrix3d r;
    r.row(0) = xr;
    r.row(1) = yr;
    r.row(2) = z;
    // Re-orthonormalize against rounding.
    Eigen::JacobiSVD<Matrix3d> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
    m.rotation = svd.matrixU() * svd.matrixV().transpose();
    m.translation_mm = -m.rotation * centre;

    cam.response.gain = 190.0 * rng.Uniform(0.8, 1.2);
    cam.response.offset = rng.Uniform(-8.0, 12.0);
    cam.response.noise_sigma = rng.Uniform(1.5, 3.0);
  }
  for (const auto& [a, b] : g.edges) {
    const auto ia = camera_of_vertex.find(a), ib = camera_of_vertex.find(b);
    if (ia == camera_of_vertex.end() || ib == camera_of_vertex.end()) continue;
    cameras[ia->second].rig.neighbours.push_back(cameras[ib->second].rig.model.id);
    cameras[ib->second].rig.neighbours.push_back(cameras[ia->second].rig.model.id);
  }
  for (auto& cam : cameras) std::sort(cam.rig.neighbours.begin(), cam.rig.neighbours.end());
  return cameras;
}

}  // namespace dome::synth
