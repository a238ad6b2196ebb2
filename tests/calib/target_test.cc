#include "calib/target.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::calib {
namespace {

namespace fs = std::filesystem;


void Write(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

std::string GridTargetJson(int n, double pitch, const std::string& extra_point = "") {
  std::string s = R"({"format_version": 1, "frame": "world", "marker_radius_mm": 45,
                     "key_marker_radius_mm": 60, "points": [)";
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      s += (i || j ? "," : "") + std::string("{\"id\": ") + std::to_string(n * j + i) +
           ", \"x_mm\": " + std::to_string(pitch * i) + ", \"y_mm\": " + std::to_string(pitch * j) +
           ", \"z_mm\": 0}";
    }
  }
  return s + extra_point + "]}";
}

TEST(Target, ReadsAndInfersOneGrid) {
  const dome::testing::TempDir tmp;
  const fs::path dir = tmp.path();
  Write(dir / "target.json", GridTargetJson(5, 300));
  const Target t = ReadTarget(dir / "target.json");
  ASSERT_EQ(t.points.size(), 25u);
  const GridLayout layout = InferGridLayout(t);
  ASSERT_EQ(layout.grids.size(), 1u);
  EXPECT_EQ(layout.grids[0].n, 5);
  EXPECT_NEAR(layout.grids[0].normal.z(), 1.0, 1e-12);
}

TEST(Target, NanCoordinateIsAnError) {
  const dome::testing::TempDir tmp;
  const fs::path dir = tmp.path();
  Write(dir / "target.json",
        GridTargetJson(3, 100, R"(,{"id": 99, "x_mm": "NaN", "y_mm": 0, "z_mm": 0})"));
  testing::ExpectInputError([&] { ReadTarget(dir / "target.json"); },
                            {"target.json", "points[9]", "id 99", "finite"});
}

TEST(Target, DuplicateIdIsAnError) {
  const dome::testing::TempDir tmp;
  const fs::path dir = tmp.path();
  Write(dir / "target.json",
        GridTargetJson(3, 100, R"(,{"id": 4, "x_mm": 5, "y_mm": 0, "z_mm": 0})"));
  testing::ExpectInputError([&] { ReadTarget(dir / "target.json"); },
                            {"target.json", "points[9].id", "duplicate id 4"});
}

TEST(Target, UnknownFieldAndMissingFile) {
  const dome::testing::TempDir tmp;
  const fs::path dir = tmp.path();
  Write(dir / "target.json", R"({"format_version": 1, "bogus": 3})");
  testing::ExpectInputError([&] { ReadTarget(dir / "target.json"); }, {"target.json", "bogus"});
  testing::ExpectInputError([&] { ReadTarget(dir / "absent.json"); }, {"absent.json"});
}

// A grid and, after it, plain marks in its plane (grid_points = 9): the layout lists
// them apart; a plain mark off the plane, or more grid points than points, is an error.
TEST(Target, GridWithPlainMarks) {
  const dome::testing::TempDir tmp;
  const fs::path dir = tmp.path();
  std::string json = GridTargetJson(3, 100,
                                    R"(,{"id": 20, "x_mm": 900, "y_mm": -50, "z_mm": 0},
                                       {"id": 11, "x_mm": -700, "y_mm": 420, "z_mm": 0})");
  json.insert(json.find(R"("points")"), R"("grid_points": 9, )");
  Write(dir / "target.json", json);
  const Target t = ReadTarget(dir / "target.json");
  EXPECT_EQ(t.grid_points, 9);
  const GridLayout layout = InferGridLayout(t);
  ASSERT_EQ(layout.grids.size(), 1u);
  EXPECT_EQ(layout.grids[0].n, 3);
  EXPECT_EQ(layout.plain_ids, (std::vector<int>{11, 20}));

  std::string off = GridTargetJson(3, 100, R"(,{"id": 20, "x_mm": 900, "y_mm": 0, "z_mm": 40})");
  off.insert(off.find(R"("points")"), R"("grid_points": 9, )");
  Write(dir / "off.json", off);
  const Target t_off = ReadTarget(dir / "off.json");
  testing::ExpectInputError([&] { InferGridLayout(t_off); },
                            {"off.json", "plain mark id 20", "not in the plane"});

  std::string many = GridTargetJson(3, 100);
  many.insert(many.find(R"("points")"), R"("grid_points": 10, )");
  Write(dir / "many.json", many);
  testing::ExpectInputError([&] { ReadTarget(dir / "many.json"); },
                            {"many.json: grid_points", "10 grid points", "only 9"});
}

TEST(Target, NotAGridIsAnError) {
  const dome::testing::TempDir tmp;
  const fs::path dir = tmp.path();
  Write(dir / "target.json",
        R"({"format_version": 1, "marker_radius_mm": 1, "key_marker_radius_mm": 2,
      "points": [{"id": 0, "x_mm": 0}, {"id": 1, "x_mm": 7}, {"id": 2, "y_mm": 3}]})");
  const Target t = ReadTarget(dir / "target.json");
  testing::ExpectInputError([&] { InferGridLayout(t); }, {"target.json", "grids"});
}

}  // namespace
}  // namespace dome::calib
