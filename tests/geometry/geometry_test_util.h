// Helpers shared by the dome_geometry tests: data paths, scratch folders, InputError
// expectations and typical cameras.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <initializer_list>
#include <random>
#include <string>

#include "core/error.h"
#include "geometry/tsai_camera.h"

namespace dome::geometry::testing {

// Root of the shared real data (DOME_SHARED_DIR/data).
inline std::string DataDir() { return std::string(DOME_SHARED_DIR) + "/data"; }

// Skips the current test (from its body) when a data folder is absent.
#define DOME_SKIP_WITHOUT(folder)                                                        \
  do {                                                                                   \
    if (!std::filesystem::is_directory(folder)) GTEST_SKIP() << "no data: " << (folder); \
  } while (false)

// A fresh folder under the system temp folder, removed with everything in it.
class ScratchDir {
 public:
  ScratchDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = std::filesystem::temp_directory_path() /
            ("dome_geometry_" + std::string(info->test_suite_name()) + "_" + info->name() + "_" +
             std::to_string(std::random_device{}()));
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  std::string File(const std::string& name) const { return (path_ / name).string(); }
  std::string path() const { return path_.string(); }

 private:
  std::filesystem::path path_;
};

// Expects fn() to throw core::InputError whose message contains every fragment.
template <typename Fn>
void ExpectInputError(Fn&& fn, std::initializer_list<std::string> fragments) {
  try {
    fn();
    ADD_FAILURE() << "no InputError thrown";
  } catch (const core::InputError& e) {
    for (const std::string& fragment : fragments) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos)
          << "message '" << e.what() << "' lacks '" << fragment << "'";
    }
  }
}

// A camera like the EPFL terrace ones (720x576, 23 um pitch, f = 20 mm), with sx != 1
// and ncx != nfx so that the x scale factors are exercised, looking at the world origin
// from about 5 m.
inline TsaiCamera TypicalCamera(double kappa1_per_mm2) {
  TsaiCamera camera;
  camera.id = "typical";
  camera.width_px = 720;
  camera.height_px = 576;
  camera.sensor.ncx = 600;
  camera.sensor.nfx = 720;
  camera.sensor.dx_mm = 0.0276;  // dpx = 0.023 mm
  camera.sensor.dy_mm = 0.023;
  camera.focal_mm = 20.16192;
  camera.kappa1_per_mm2 = kappa1_per_mm2;
  camera.cx_px = 366.514507;
  camera.cy_px = 305.832552;
  camera.sx = 1.013;
  camera.rotation = RotationFromTsaiAngles(1.9007833770, 0.49730769727, 0.18415452559);
  camera.translation_mm = Eigen::Vector3d(-4844.1913843, 551.09448682, 4966.7438357);
  return camera;
}

}  // namespace dome::geometry::testing
