#include "pipeline/settings.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <set>
#include <string>
#include <vector>

#include "io/depth_tiff.h"
#include "pipeline/stages.h"
#include "stereo/take_stereo.h"
#include "take/take.h"
#include "testing/expect_error.h"
#include "testing/run_command.h"
#include "testing/temp_dir.h"

namespace dome::pipeline {
namespace {

using stereo::StereoOptions;
using stereo::TakeStereoOptions;

void WriteText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path) << text;
}

// OUT/<instant>/depth/c00.tiff of a `dome stereo --camera c00` run; empty when missing.
cv::Mat ReadC00Depth(const std::string& out) {
  for (const auto& e : std::filesystem::recursive_directory_iterator(out)) {
    if (e.path().filename() == "c00.tiff" && e.path().parent_path().filename() == "depth") {
      return io::ReadDepthTiff(e.path());
    }
  }
  return cv::Mat();
}

TEST(StereoOptionsJsonTest, RoundTripKeepsEveryField) {
  TakeStereoOptions o;
  o.stereo.z_min_mm = 600;
  o.stereo.z_max_mm = 4200;
  o.stereo.num_levels = 123;
  o.stereo.level_step_px = 0.75;
  o.stereo.window_sizes_px = {5, 9, 13};
  o.stereo.normalize_contrast = true;
  o.stereo.sqrt_greys = true;
  o.stereo.outside_difference_grey = 33;
  o.stereo.min_curvature = 1.5;
  o.stereo.min_uniqueness = 0.4;
  o.stereo.min_texture_grey = 3;
  o.cluster.max_neighbours = 2;
  o.cluster.max_axis_angle_deg = 45;
  o.stereo.prewarp_neighbours = !StereoOptions().prewarp_neighbours;
  o.stereo.speckle.min_area_px = 500;
  o.stereo.speckle.max_step_mm = 0.25;
  const TakeStereoOptions r = ParseStereoOptionsJson(StereoOptionsToJson(o), "test");
  EXPECT_EQ(r.stereo.z_min_mm, 600);
  EXPECT_EQ(r.stereo.z_max_mm, 4200);
  EXPECT_EQ(r.stereo.num_levels, 123);
  EXPECT_EQ(r.stereo.level_step_px, 0.75);
  EXPECT_EQ(r.stereo.window_sizes_px, (std::vector<int>{5, 9, 13}));
  EXPECT_TRUE(r.stereo.normalize_contrast);
  EXPECT_TRUE(r.stereo.sqrt_greys);
  EXPECT_EQ(r.stereo.outside_difference_grey, 33);
  EXPECT_EQ(r.stereo.min_curvature, 1.5);
  EXPECT_EQ(r.stereo.min_uniqueness, 0.4);
  EXPECT_EQ(r.stereo.min_texture_grey, 3);
  EXPECT_EQ(r.cluster.max_neighbours, 2);
  EXPECT_EQ(r.cluster.max_axis_angle_deg, 45);
  EXPECT_EQ(r.stereo.prewarp_neighbours, !StereoOptions().prewarp_neighbours);
  EXPECT_EQ(r.stereo.speckle.min_area_px, 500);
  EXPECT_EQ(r.stereo.speckle.max_step_mm, 0.25);
}

TEST(StereoOptionsJsonTest, MissingFieldsKeepTheBase) {
  TakeStereoOptions base;
  base.stereo.min_texture_grey = 7;
  base.stereo.num_threads = 3;
  // Proto and lowerCamelCase names both map.
  const TakeStereoOptions r =
      ParseStereoOptionsJson(R"({"zMinMm": 900, "window_sizes_px": [11]})", "test", base);
  EXPECT_EQ(r.stereo.z_min_mm, 900);
  EXPECT_EQ(r.stereo.window_sizes_px, std::vector<int>{11});
  EXPECT_EQ(r.stereo.z_max_mm, StereoOptions{}.z_max_mm);
  EXPECT_EQ(r.stereo.min_texture_grey, 7);
  EXPECT_EQ(r.stereo.num_threads, 3);
}

TEST(StereoOptionsJsonTest, BadInputNamesTheField) {
  using dome::testing::ExpectInputError;
  ExpectInputError([] { ParseStereoOptionsJson(R"({"zmin": 900})", "o.json"); },
                   {"o.json", "zmin"});
  ExpectInputError([] { ParseStereoOptionsJson(R"({"num_levels": "many"})", "o.json"); },
                   {"o.json", "num_levels"});
  ExpectInputError([] { ParseStereoOptionsJson("[1, 2]", "o.json"); }, {"o.json"});
  ExpectInputError(
      [] { ParseStereoOptionsJson(R"({"z_min_mm": 3000, "z_max_mm": 2000})", "o.json"); },
      {"o.json: z_max_mm", "greater than z_min_mm"});
  ExpectInputError([] { ParseStereoOptionsJson(R"({"window_sizes_px": [4]})", "o.json"); },
                   {"o.json: window_sizes_px", "odd"});
  ExpectInputError([] { ParseStereoOptionsJson(R"({"max_neighbours": 0})", "o.json"); },
                   {"o.json: max_neighbours"});
  ExpectInputError([] { ParseStereoOptionsJson(R"({"speckle_area_px": 100})", "o.json"); },
                   {"o.json: speckle_step_mm", "positive"});
  // The derived session's fields: clip box and per-camera depth ranges.
  ExpectInputError(
      [] {
        ParseStereoOptionsJson(R"({"clip_min_mm": [0, 0], "clip_max_mm": [1, 1, 1]})", "o.json");
      },
      {"o.json: clip_min_mm", "3 numbers"});
  ExpectInputError(
      [] {
        ParseStereoOptionsJson(R"({"clip_min_mm": [0, 0, 5], "clip_max_mm": [1, 1, 1]})", "o.json");
      },
      {"o.json: clip_max_mm", "exceed clip_min_mm"});
  ExpectInputError(
      [] {
        ParseStereoOptionsJson(
            R"({"camera_depths": [{"camera": "c1", "z_min_mm": 900, "z_max_mm": 800}]})", "o.json");
      },
      {"o.json: camera_depths", "'c1'", "z_min_mm < z_max_mm"});
  ExpectInputError(
      [] {
        ParseStereoOptionsJson(R"({"camera_depths": [{"camera": "c1", "z_min_mm": 1, "z_max_mm": 2},
                                                    {"camera": "c1", "z_min_mm": 1, "z_max_mm": 3}]})",
                               "o.json");
      },
      {"o.json: camera_depths", "'c1' twice"});
  dome::testing::TempDir dir;
  ExpectInputError([&] { ReadStereoOptionsJson(dir / "missing.json"); }, {"missing.json"});
}

// `dome stereo --options FILE`: the file sets the options, flags given override it,
// --profile real picks RealImageOptions(), and a bad file stops the command with the
// field named.
TEST(StereoOptionsJsonTest, CommandReadsOptionsFile) {
  dome::testing::TempDir dir;
  const std::string take = dir.File("take");
  auto synth = dome::testing::RunDomeBinary(
      "synth --preset small --instants 1 --no-tape "
      "--no-calib --threads 2 --out " +
      take);
  ASSERT_EQ(synth.exit_code, 0) << synth.output;
  WriteText(dir / "opts.json", R"({"window_sizes_px": [5, 9], "min_uniqueness": 0.3})");
  const std::string out = dir.File("out");
  auto run = dome::testing::RunDomeBinary("stereo " + take + " --camera c00 --options " +
                                          dir.File("opts.json") + " --windows 7 --threads 2 " +
                                          "--no-preview --out " + out);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  // --windows 7 replaced the file's [5, 9]: one range image, window 7.
  EXPECT_NE(run.output.find("w7 density"), std::string::npos) << run.output;
  EXPECT_EQ(run.output.find("w9"), std::string::npos) << run.output;
  EXPECT_EQ(ReadC00Depth(out).cols, 160);

  // The real profile: windows 9 and 13.
  auto real = dome::testing::RunDomeBinary("stereo " + take +
                                           " --camera c00 --profile real --threads 2 "
                                           "--no-preview --out " +
                                           dir.File("out_real"));
  ASSERT_EQ(real.exit_code, 0) << real.output;
  EXPECT_NE(real.output.find("w9 density"), std::string::npos) << real.output;
  EXPECT_NE(real.output.find("w13 density"), std::string::npos) << real.output;

  WriteText(dir / "bad.json", R"({"z_min_mm": -5})");
  auto bad = dome::testing::RunDomeBinary("stereo " + take + " --camera c00 --options " +
                                          dir.File("bad.json") + " --out " + out);
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.output.find("bad.json: z_min_mm"), std::string::npos) << bad.output;

  // The exact per-pixel warp, by flag or by "prewarp_neighbours": false in the file: the
  // same depths, close to the default ones. (The small dome's clusters span it: a
  // neighbour of c00 has the near depth planes behind it, so the default falls back to
  // the exact warp here; cost_kernel_test and multi_baseline_test compare the warps.)
  WriteText(dir / "exact.json", R"({"prewarp_neighbours": false})");
  const std::string common =
      "stereo " + take + " --camera c00 --windows 7 --threads 2 --no-preview";
  const auto by_flag =
      dome::testing::RunDomeBinary(common + " --exact-warp --out " + dir.File("x1"));
  const auto by_file = dome::testing::RunDomeBinary(
      common + " --options " + dir.File("exact.json") + " --out " + dir.File("x2"));
  const auto pre = dome::testing::RunDomeBinary(common + " --out " + dir.File("p"));
  ASSERT_EQ(by_flag.exit_code, 0) << by_flag.output;
  ASSERT_EQ(by_file.exit_code, 0) << by_file.output;
  ASSERT_EQ(pre.exit_code, 0) << pre.output;
  const cv::Mat exact = ReadC00Depth(dir.File("x1")), prewarped = ReadC00Depth(dir.File("p"));
  ASSERT_FALSE(exact.empty());
  ASSERT_FALSE(prewarped.empty());
  EXPECT_EQ(cv::norm(exact, ReadC00Depth(dir.File("x2")), cv::NORM_INF), 0.0);
  std::vector<double> rel;
  for (int y = 0; y < exact.rows; ++y) {
    for (int x = 0; x < exact.cols; ++x) {
      const float a = exact.at<float>(y, x), b = prewarped.at<float>(y, x);
      if (a > 0 && b > 0) rel.push_back(std::abs(a - b) / a);
    }
  }
  ASSERT_GT(rel.size(), 1000u);
  std::nth_element(rel.begin(), rel.begin() + rel.size() / 2, rel.end());
  EXPECT_LT(rel[rel.size() / 2], 0.01);  // half the depths within 1% of each other

  // Square roots of the greys, by flag or by "sqrt_greys": true in the file: the same
  // depths, which are not those of the linear greys.
  WriteText(dir / "sqrt.json", R"({"sqrt_greys": true})");
  const auto sqrt_flag =
      dome::testing::RunDomeBinary(common + " --sqrt-greys --out " + dir.File("s1"));
  const auto sqrt_file = dome::testing::RunDomeBinary(
      common + " --options " + dir.File("sqrt.json") + " --out " + dir.File("s2"));
  ASSERT_EQ(sqrt_flag.exit_code, 0) << sqrt_flag.output;
  ASSERT_EQ(sqrt_file.exit_code, 0) << sqrt_file.output;
  const cv::Mat rooted = ReadC00Depth(dir.File("s1"));
  ASSERT_FALSE(rooted.empty());
  EXPECT_EQ(cv::norm(rooted, ReadC00Depth(dir.File("s2")), cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(rooted, prewarped, cv::NORM_INF), 0.0);
}

// Each option is one row of its table: every field of the proto messages is bound to
// an options field (the coarse-to-fine block and clip box are messages of their own),
// and round trips through it.
TEST(SettingTables, EveryProtoFieldHasItsRow) {
  auto names = [](const auto& fields) {
    std::set<std::string> n;
    for (const auto& f : fields) n.insert(f.proto_name);
    return n;
  };
  auto expect_all = [](const google::protobuf::Descriptor* d, const std::set<std::string>& rows,
                       const std::set<std::string>& apart) {
    for (int i = 0; i < d->field_count(); ++i) {
      const std::string name = d->field(i)->name();
      EXPECT_TRUE(rows.count(name) || apart.count(name)) << d->name() << "." << name;
    }
    EXPECT_EQ(rows.size() + apart.size(), size_t(d->field_count())) << d->name();
  };
  expect_all(runtime::StereoSettings::descriptor(), names(StereoSettingFields()),
             {"coarse_to_fine", "clip_min_mm", "clip_max_mm", "camera_depths"});
  expect_all(runtime::CoarseToFineSettings::descriptor(), names(CoarseToFineSettingFields()),
             {"clip_min_mm", "clip_max_mm"});
  expect_all(runtime::FusionSettings::descriptor(), names(FusionSettingFields()), {});

  fusion::FusionOptions f;
  f.truncation_mm = 7;
  f.front_clamp_mm = 8;
  f.max_depth_jump_ratio = 0.2;
  f.min_depth_mm = 3;
  f.min_consistent_views = 2;
  f.consistency_tolerance_mm = 9;
  f.min_weight = 1.5;
  const fusion::FusionOptions g = FromFusionSettings(ToFusionSettings(f), 50, "test");
  EXPECT_EQ(g.truncation_mm, 7);
  EXPECT_EQ(g.front_clamp_mm, 8);
  EXPECT_EQ(g.max_depth_jump_ratio, 0.2);
  EXPECT_EQ(g.min_depth_mm, 3);
  EXPECT_EQ(g.min_consistent_views, 2);
  EXPECT_EQ(g.consistency_tolerance_mm, 9);
  EXPECT_EQ(g.min_weight, 1.5);
  // Unset: the derived defaults of the voxel (pipeline/defaults.h).
  const fusion::FusionOptions d = FromFusionSettings({}, 50, "test");
  EXPECT_EQ(d.truncation_mm, 150);
  EXPECT_EQ(d.front_clamp_mm, 150);
  EXPECT_EQ(d.consistency_tolerance_mm, 50);

  stereo::CoarseToFineOptions c;
  c.tile_px = 48;
  c.clip = true;
  c.clip_min_mm = Eigen::Vector3d(-1, -2, -3);
  c.clip_max_mm = Eigen::Vector3d(1, 2, 3);
  c.clip_pad_mm = 4;
  const stereo::CoarseToFineOptions back =
      FromCoarseToFineSettings(ToCoarseToFineSettings(c), "test");
  EXPECT_EQ(back.tile_px, 48);
  EXPECT_TRUE(back.clip);
  EXPECT_EQ(back.clip_max_mm, c.clip_max_mm);
  EXPECT_EQ(back.clip_pad_mm, 4);
  EXPECT_FALSE(FromCoarseToFineSettings(ToCoarseToFineSettings({}), "test").clip);
}

// `dome stereo --options F` with a "coarse_to_fine" block runs coarse to fine: the depth
// map it writes is the coarse-to-fine stage's on the same inputs, not the full range's.
TEST(StereoOptionsJsonTest, CommandRunsCoarseToFineFromTheOptionsFile) {
  dome::testing::TempDir dir;
  const std::string take = dir.File("take");
  ASSERT_EQ(dome::testing::RunDomeBinary("synth --preset small --instants 1 --no-tape --no-calib "
                                         "--threads 2 --out " +
                                         take)
                .exit_code,
            0);
  // Around the batter (synth/batter.h), and a coarse pass at half resolution.
  const std::string block =
      R"({"window_sizes_px": [7], "coarse_to_fine": {"coarse_factor": 2, "tile_px": 32,)"
      R"( "clip_min_mm": [-800, -800, 0], "clip_max_mm": [800, 800, 2200]}})";
  WriteText(dir / "c2f.json", block);
  const std::string common = "stereo " + take + " --camera c00 --threads 2 --no-preview";
  const auto c2f = dome::testing::RunDomeBinary(common + " --options " + dir.File("c2f.json") +
                                                " --out " + dir.File("c2f"));
  ASSERT_EQ(c2f.exit_code, 0) << c2f.output;
  const auto full = dome::testing::RunDomeBinary(common + " --windows 7 --out " + dir.File("full"));
  ASSERT_EQ(full.exit_code, 0) << full.output;

  const TakeStereoOptions options = ParseStereoOptionsJson(block, "test");
  ASSERT_TRUE(options.coarse_to_fine);
  const take::Take t = take::OpenTake(take);
  const stereo::StereoInput input =
      stereo::LoadStereoInput(t, t.instants.front(), "c00", options.cluster);
  TakeStereoOptions threads = options;
  threads.stereo.num_threads = 2;
  const cv::Mat expected = Stereo(input, threads, "test").range_images.at(0).depth_mm;
  const cv::Mat written = ReadC00Depth(dir.File("c2f"));
  ASSERT_EQ(written.size(), expected.size());
  EXPECT_EQ(cv::norm(written, expected, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::countNonZero(written > 0), written.total() / 20);
  EXPECT_GT(cv::norm(written, ReadC00Depth(dir.File("full")), cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace dome::pipeline
