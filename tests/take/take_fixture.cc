#include "take_fixture.h"

#include <Eigen/Geometry>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "schema/rig_json.h"
#include "take/take.h"
#include "take/timecode.h"

namespace dome::take::testing {

namespace fs = std::filesystem;

geometry::Rig MakeRingRig(int cameras, int width_px, int height_px) {
  geometry::Rig rig;
  rig.source = "test";
  for (int i = 0; i < cameras; ++i) {
    geometry::RigCamera cam;
    geometry::TsaiCamera& m = cam.model;
    m.id = "c" + std::to_string(i);
    m.width_px = width_px;
    m.height_px = height_px;
    m.sensor = {static_cast<double>(width_px), static_cast<double>(width_px), 0.01, 0.01};
    m.focal_mm = 0.01 * width_px;  // ~53 degrees horizontal field of view
    m.kappa1_per_mm2 = 0.01;
    m.cx_px = width_px / 2.0;
    m.cy_px = height_px / 2.0;
    m.sx = 1.0;
    const double a = 2 * M_PI * i / cameras;
    const Eigen::Vector3d centre(2000 * std::cos(a), 2000 * std::sin(a), 1000);
    const Eigen::Vector3d z = (-centre).normalized();
    const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
    const Eigen::Vector3d y = z.cross(x);
    m.rotation.row(0) = x;
    m.rotation.row(1) = y;
    m.rotation.row(2) = z;
    m.translation_mm = -m.rotation * centre;
    rig.cameras.push_back(cam);
  }
  return rig;
}

fs::path WriteTake(const fs::path& dir, const geometry::Rig& rig, int instants) {
  CreateTakeDir(dir, true);
  schema::WriteRig(rig, dir / "rig.json");
  cv::RNG rng(7);
  for (int t = 0; t < instants; ++t) {
    const std::string instant = Timecode{0, 0, 1, 5 * t}.FolderName();
    fs::create_directories(dir / "frames" / instant);
    for (const auto& cam : rig.cameras) {
      cv::Mat image(cam.model.height_px, cam.model.width_px, CV_8UC1);
      rng.fill(image, cv::RNG::UNIFORM, 0, 256);
      cv::imwrite((dir / "frames" / instant / (cam.model.id + ".png")).string(), image);
    }
  }
  return dir;
}

}  // namespace dome::take::testing
