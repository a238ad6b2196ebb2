#include "view/output_index.h"

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "testing/expect_error.h"
#include "testing/temp_dir.h"
#include "view_fixture.h"

namespace dome::view {
namespace {

namespace fs = std::filesystem;

google::protobuf::Struct ParseJson(const std::string& json) {
  google::protobuf::Struct s;
  const auto status = google::protobuf::util::JsonStringToMessage(json, &s);
  EXPECT_TRUE(status.ok()) << status.ToString();
  return s;
}

TEST(Frustum, CornersProjectToTheImageCornersAtTheGivenDepth) {
  const geometry::Rig rig = take::testing::MakeRingRig(3, 64, 48);
  for (const auto& rc : rig.cameras) {
    geometry::TsaiCamera cam = rc.model;
    cam.kappa1_per_mm2 = 0.5;  // ~8% at the corners: they must follow the distortion
    const CameraFrustum f = FrustumOf(cam, 250.0);
    EXPECT_LT((f.centre_mm - cam.CentreWorld()).norm(), 1e-9);
    const Eigen::Vector2d expected[4] = {{-0.5, -0.5}, {63.5, -0.5}, {63.5, 47.5}, {-0.5, 47.5}};
    for (int k = 0; k < 4; ++k) {
      EXPECT_NEAR(cam.WorldToCamera(f.corners_mm[k]).z(), 250.0, 1e-6);
      Eigen::Vector2d px;
      ASSERT_TRUE(cam.Project(f.corners_mm[k], &px));
      EXPECT_LT((px - expected[k]).norm(), 1e-6) << k;
    }
  }
}

TEST(Frustum, DefaultDepthIsEightPercentOfTheRigExtent) {
  // Four cameras on a 2000 mm circle: the widest pair is a diameter apart.
  EXPECT_NEAR(DefaultFrustumDepthMm(take::testing::MakeRingRig(4, 64, 48)), 0.08 * 4000, 1e-6);
  EXPECT_EQ(DefaultFrustumDepthMm(take::testing::MakeRingRig(1, 64, 48)), 300.0);
}

TEST(OutputIndex, ListsInstantsFilesCamerasAndTruth) {
  dome::testing::TempDir tmp;
  const auto f = testing::MakeViewFixture(tmp.path());
  const ViewerIndex index = BuildIndex(f.out, f.take);
  ASSERT_EQ(index.instants.size(), 3u);  // the third has no OUT folder; "logs" is not one
  EXPECT_EQ(index.instants[0].name, f.instants[0]);
  EXPECT_EQ(index.instants[0].label, "00:00:01:00");
  EXPECT_EQ(index.instants[1].label, "00:00:01:05");
  EXPECT_EQ(index.instants[0].fused, f.instants[0] + "/mesh.ply");
  EXPECT_EQ(index.instants[0].decimated, f.instants[0] + "/mesh_decimated.ply");
  EXPECT_TRUE(index.instants[0].textured_obj.empty());
  EXPECT_TRUE(index.instants[1].decimated.empty());
  EXPECT_TRUE(index.instants[2].fused.empty());
  EXPECT_FALSE(index.instants[0].truth_mesh.empty());
  EXPECT_TRUE(index.instants[1].truth_mesh.empty());
  ASSERT_EQ(index.cameras.size(), 4u);
  ASSERT_EQ(index.instants[0].cameras.size(), 4u);
  EXPECT_EQ(index.instants[0].cameras[0].image, "frames/" + f.instants[0] + "/c0.png");
  EXPECT_EQ(index.instants[0].cameras[0].depth_source, "truth");
  EXPECT_EQ(index.instants[0].cameras[1].depth_source, "");
  EXPECT_EQ(index.FindCamera("c2"), 2);
  EXPECT_EQ(index.FindInstant(f.instants[1]), 1);
  EXPECT_EQ(index.FindInstant("00-00-09-00"), -1);
}

TEST(OutputIndex, StereoDepthIsPreferredToTruth) {
  dome::testing::TempDir tmp;
  const auto f = testing::MakeViewFixture(tmp.path());
  fs::create_directories(f.out / f.instants[0] / "depth");
  fs::copy_file(f.take / "truth" / f.instants[0] / "depth" / "c0.tiff",
                f.out / f.instants[0] / "depth" / "c0.tiff");
  const ViewerIndex index = BuildIndex(f.out, f.take);
  EXPECT_EQ(index.instants[0].cameras[0].depth_source, "stereo");
  EXPECT_EQ(index.instants[0].cameras[0].depth_map, f.out / f.instants[0] / "depth" / "c0.tiff");
}

TEST(OutputIndex, JsonHasTheUrlsThePageLoads) {
  dome::testing::TempDir tmp;
  const auto f = testing::MakeViewFixture(tmp.path());
  IndexOptions o;
  o.error_range_mm = 25;
  const auto json = ParseJson(IndexJson(BuildIndex(f.out, f.take, o), false));
  EXPECT_FALSE(json.fields().at("packed").bool_value());
  EXPECT_EQ(json.fields().at("error_range_mm").number_value(), 25);
  const auto& cams = json.fields().at("cameras").list_value();
  ASSERT_EQ(cams.values_size(), 4);
  EXPECT_EQ(cams.values(1).struct_value().fields().at("id").string_value(), "c1");
  EXPECT_EQ(cams.values(1).struct_value().fields().at("corners_mm").list_value().values_size(), 4);
  const auto& instants = json.fields().at("instants").list_value();
  ASSERT_EQ(instants.values_size(), 3);
  const auto& i0 = instants.values(0).struct_value().fields();
  const std::string n0 = f.instants[0];
  EXPECT_EQ(i0.at("label").string_value(), "00:00:01:00");
  EXPECT_EQ(i0.at("fused").string_value(), "out/" + n0 + "/mesh.ply");
  EXPECT_EQ(i0.at("decimated").string_value(), "out/" + n0 + "/mesh_decimated.ply");
  EXPECT_TRUE(i0.at("textured_obj").has_null_value());
  const auto& err0 = i0.at("error").struct_value().fields();
  EXPECT_EQ(err0.at("fused").string_value(), "derived/error/" + n0 + "/fused.f32");
  const auto& c0 = i0.at("cameras").list_value().values(0).struct_value().fields();
  EXPECT_EQ(c0.at("image").string_value(), "take/frames/" + n0 + "/c0.png");
  EXPECT_EQ(c0.at("depth").string_value(), "derived/depth/" + n0 + "/c0.png");
  const auto& i1 = instants.values(1).struct_value().fields();
  EXPECT_TRUE(i1.at("error").struct_value().fields().at("fused").has_null_value());  // no truth
  EXPECT_TRUE(instants.values(2).struct_value().fields().at("fused").has_null_value());
}

// 4D files at OUT's top level are offered as sources, sorted; others are not.
TEST(OutputIndex, ListsTheFourDFilesOfTheOutputFolder) {
  dome::testing::TempDir tmp;
  const auto f = testing::MakeViewFixture(tmp.path());
  for (const char* name : {"b.dome4d", "a.dome4d", "notes.txt"})
    std::ofstream(f.out / name) << "x";
  std::filesystem::create_directories(f.out / "folder.dome4d");
  const ViewerIndex index = BuildIndex(f.out, f.take);
  EXPECT_EQ(index.sequences, (std::vector<std::string>{"a.dome4d", "b.dome4d"}));
  const auto json = ParseJson(IndexJson(index, false));
  const auto& list = json.fields().at("sequences").list_value();
  ASSERT_EQ(list.values_size(), 2);
  EXPECT_EQ(list.values(0).string_value(), "out/a.dome4d");
  // A static export opens from file://, where a 4D file cannot be streamed.
  EXPECT_EQ(ParseJson(IndexJson(index, true)).fields().at("sequences").list_value().values_size(), 0);
}

TEST(OutputIndex, WithoutATakeThereAreNoCameras) {
  dome::testing::TempDir tmp;
  const auto f = testing::MakeViewFixture(tmp.path());
  const ViewerIndex index = BuildIndex(f.out, std::nullopt);
  EXPECT_TRUE(index.cameras.empty());
  EXPECT_EQ(index.instants.size(), 2u);
}

TEST(OutputIndex, BadInputNamesTheFolderOrOption) {
  dome::testing::TempDir tmp;
  dome::testing::ExpectInputError([&] { BuildIndex(tmp / "nothing", std::nullopt); },
                                  {"nothing", "expected an output folder"});
  const auto f = testing::MakeViewFixture(tmp.path());
  dome::testing::ExpectInputError([&] { BuildIndex(f.out, tmp / "no-take"); }, {"no-take"});
  IndexOptions o;
  o.error_range_mm = 0;
  dome::testing::ExpectInputError([&] { BuildIndex(f.out, std::nullopt, o); },
                                  {"--error-range-mm", "positive"});
}

}  // namespace
}  // namespace dome::view
