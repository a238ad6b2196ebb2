#include "schema/rig_json.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>

#include "core/error.h"
#include "take_fixture.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::schema {
namespace {

using geometry::Rig;
using geometry::RigCamera;
using take::testing::MakeRingRig;

using dome::testing::ExpectInputError;

TEST(Rig, JsonRoundTripIsExact) {
  Rig rig = MakeRingRig(3, 64, 48);
  rig.cameras[1].neighbours = {"c0", "c2"};
  rig.source = "halcon";
  rig.source_unit = "m";
  rig.source_unit_mm = 1000;
  const Rig back = ParseRigJson(RigToJson(rig), "mem");
  ASSERT_EQ(back.cameras.size(), 3u);
  EXPECT_EQ(back.source, "halcon");
  EXPECT_EQ(back.source_unit_mm, 1000);
  for (size_t i = 0; i < 3; ++i) {
    const auto& a = rig.cameras[i].model;
    const auto& b = back.cameras[i].model;
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.focal_mm, b.focal_mm);
    EXPECT_EQ(a.kappa1_per_mm2, b.kappa1_per_mm2);
    EXPECT_EQ(a.rotation, b.rotation);  // bit-exact: JSON doubles round-trip
    EXPECT_EQ(a.translation_mm, b.translation_mm);
    EXPECT_EQ(rig.cameras[i].neighbours, back.cameras[i].neighbours);
  }
}

TEST(Rig, FileRoundTrip) {
  const dome::testing::TempDir tmp;
  const std::filesystem::path dir = tmp.path();
  const Rig rig = MakeRingRig(2, 32, 24);
  WriteRig(rig, dir / "rig.json");
  const Rig back = ReadRig(dir / "rig.json");
  ASSERT_EQ(back.cameras.size(), 2u);
  EXPECT_EQ(back.cameras[1].model.translation_mm, rig.cameras[1].model.translation_mm);
  // Written atomically: nothing but rig.json is left in the folder.
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir),
                          std::filesystem::directory_iterator()),
            1);
}

TEST(Rig, MissingFileNamesIt) {
  ExpectInputError([] { ReadRig("/nonexistent/take/rig.json"); },
                   {"/nonexistent/take/rig.json", "no such file"});
}

TEST(Rig, UnwritableFolderNamesIt) {
  ExpectInputError([] { WriteRig(MakeRingRig(1, 8, 8), "/proc/dome/rig.json"); },
                   {"/proc/dome/rig.json", "cannot write"});
}

TEST(Rig, UnknownFieldIsRejectedByName) {
  ExpectInputError(
      [] {
        ParseRigJson(R"({"format_version": 1, "cameras": [{"id": "a", "focalmm": 3}]})", "r.json");
      },
      {"r.json", "focalmm", "Cannot find field"});
}

TEST(Rig, MalformedJsonNamesFile) {
  ExpectInputError([] { ParseRigJson(R"({"format_version": 1, "cameras": [)", "r.json"); },
                   {"r.json", "invalid rig JSON"});
}

TEST(Rig, WrongTypeNamesField) {
  ExpectInputError(
      [] {
        ParseRigJson(R"({"format_version": 1, "cameras": [{"id": "a", "width_px": "wide"}]})",
                     "r.json");
      },
      {"r.json", "cameras[0].width_px"});
}

TEST(Rig, FormatVersionChecked) {
  ExpectInputError([] { ParseRigJson(R"({"format_version": 7, "cameras": []})", "r.json"); },
                   {"r.json: format_version", "expected 1, got 7"});
}

class RigFieldTest : public ::testing::Test {
 protected:
  // JSON of a valid 2-camera rig after `edit` changed camera 1.
  template <typename Edit>
  std::string With(Edit edit) {
    Rig rig = MakeRingRig(2, 16, 12);
    edit(rig.cameras[1]);
    // RigToJson does not check, so invalid values reach the parser as a user would write them.
    return RigToJson(rig);
  }
};

TEST_F(RigFieldTest, NanFocalLength) {
  const auto json =
      With([](RigCamera& c) { c.model.focal_mm = std::numeric_limits<double>::quiet_NaN(); });
  ExpectInputError([&] { ParseRigJson(json, "r.json"); }, {"r.json", "cameras[1]", "focal_mm"});
}

TEST_F(RigFieldTest, OpenCvLensRoundTripsAndItsCountIsChecked) {
  Rig rig = MakeRingRig(2, 16, 12);
  rig.cameras[1].model.kappa1_per_mm2 = 0;  // one distortion model per camera
  rig.cameras[1].model.lens = {-0.25, 0.1, 0.001, -0.0005, -0.02};
  const Rig back = ParseRigJson(RigToJson(rig), "r.json");
  EXPECT_EQ(back.cameras[1].model.lens.k1, -0.25);
  EXPECT_EQ(back.cameras[1].model.lens.p2, -0.0005);
  EXPECT_EQ(back.cameras[1].model.lens.k3, -0.02);
  EXPECT_FALSE(back.cameras[0].model.lens.Any());
  std::string json = RigToJson(rig);
  const auto at = json.find("-0.02");
  ASSERT_NE(at, std::string::npos);
  json.erase(json.rfind(',', at), at + 5 - json.rfind(',', at));  // drop k3
  ExpectInputError([&] { ParseRigJson(json, "r.json"); },
                   {"r.json", "cameras[1]", "opencv_distortion", "expected 5 values"});
}

TEST_F(RigFieldTest, NonOrthonormalRotation) {
  const auto json = With([](RigCamera& c) { c.model.rotation(0, 1) += 0.01; });
  ExpectInputError([&] { ParseRigJson(json, "r.json"); }, {"r.json", "cameras[1]", "rotation"});
}

TEST_F(RigFieldTest, ReflectionIsNotARotation) {
  const auto json = With([](RigCamera& c) { c.model.rotation.row(2) *= -1; });
  ExpectInputError([&] { ParseRigJson(json, "r.json"); }, {"cameras[1]", "rotation"});
}

TEST_F(RigFieldTest, ZeroImageSize) {
  const auto json = With([](RigCamera& c) { c.model.width_px = 0; });
  ExpectInputError([&] { ParseRigJson(json, "r.json"); }, {"cameras[1]", "width_px"});
}

TEST_F(RigFieldTest, DuplicateId) {
  const auto json = With([](RigCamera& c) { c.model.id = "c0"; });
  ExpectInputError([&] { ParseRigJson(json, "r.json"); },
                   {"cameras[1]", "duplicate camera id 'c0'"});
}

TEST_F(RigFieldTest, IdWithSlash) {
  const auto json = With([](RigCamera& c) { c.model.id = "../x"; });
  ExpectInputError([&] { ParseRigJson(json, "r.json"); }, {"cameras[1]", ".id"});
}

TEST_F(RigFieldTest, UnknownNeighbour) {
  const auto json = With([](RigCamera& c) { c.neighbours = {"c0", "c9"}; });
  ExpectInputError([&] { ParseRigJson(json, "r.json"); }, {"cameras[1]", "neighbours", "'c9'"});
}

TEST(Rig, RotationNeedsNineValues) {
  ExpectInputError(
      [] {
        ParseRigJson(
            R"({"format_version": 1, "cameras": [{"id": "a", "sensor": {}, "rotation": [1, 0, 0]}]})",
            "r.json");
      },
      {"r.json: cameras[0] (id 'a').rotation", "expected 9 values"});
}

TEST(Rig, EmptyRigRejected) {
  ExpectInputError([] { ParseRigJson(R"({"format_version": 1})", "r.json"); },
                   {"r.json: cameras", "at least one camera"});
}

}  // namespace
}  // namespace dome::schema
