// Helpers shared by the dome_geometry tests: data paths, scratch folders, InputError
// expectations and typical cameras.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <random>
#include <string>

#include "core/error.h"
#include "geometry/tsai_camera.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::geometry::testing {

// Root of the shared real data (DOME_SHARED_DIR/data).
inline std::string DataDir() { return std::string(DOME_SHARED_DIR) + "/data"; }

// Skips the current test (from its body) when a data folder is absent.
#define DOME_SKIP_WITHOUT(folder)                                                        \
  do {                                                                                   \
    if (!std::filesystem::is_directory(folder)) GTEST_SKIP() << "no data: " << (folder); \
  } while (false)

// Scratch folders and the InputError check are shared by every test (tests/testing/).
using ScratchDir = dome::testing::TempDir;
using dome::testing::ExpectInputError;

// Writes `text` to `path` (test input files written by hand).
inline void WriteFile(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

// `text` with the first occurrence of `from` replaced by `to` (a test failure when
// `from` is absent): for breaking one field of a valid file.
inline std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) {
    text.replace(at, from.size(), to);
  }
  return text;
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
