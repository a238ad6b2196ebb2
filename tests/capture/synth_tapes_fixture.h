// A test suite over the small synthetic take rendered once with its tapes (FFV1
// video with VITC, `dome synth --tape-video`): the capture tests play those tapes and
// compare what lands in a take with the rendered frames.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>

#include "io/image_io.h"
#include "synth/synth.h"
#include "testing/temp_dir.h"

namespace dome::capture::test_tapes {

class SmallTakeWithTapes : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new dome::testing::TempDir();
    synth::SynthOptions options;
    options.preset = "small";
    options.write_calibration = false;
    options.write_tape_video = true;
    summary_ = new synth::SynthSummary(synth::GenerateTake(options, dir_->path() / "synth"));
  }
  static void TearDownTestSuite() {
    delete summary_;
    delete dir_;
    summary_ = nullptr;
    dir_ = nullptr;
  }
  static std::filesystem::path Synth() { return dir_->path() / "synth"; }
  // Every instant of the take: 10:00 to its last (every 5th frame).
  static std::string Range() {
    return "00:00:10:00-00:00:10:" + summary_->instants.back().substr(9);
  }
  static int Wanted() { return static_cast<int>(summary_->instants.size()); }

  // Every instant's frame of `camera` in `take` is there and pixel-identical to the
  // synthetic take's image.
  static void ExpectFramesEqualSynth(const std::filesystem::path& take, const std::string& camera) {
    for (const std::string& instant : summary_->instants) {
      const auto got = take / "frames" / instant / (camera + ".png");
      ASSERT_TRUE(std::filesystem::exists(got)) << got;
      const cv::Mat a = io::ReadImage(got, io::ImageMode::kGray8);
      const cv::Mat b =
          io::ReadImage(Synth() / "frames" / instant / (camera + ".png"), io::ImageMode::kGray8);
      ASSERT_EQ(a.size(), b.size()) << got;
      EXPECT_EQ(cv::countNonZero(a != b), 0) << got;
    }
  }

  static inline dome::testing::TempDir* dir_ = nullptr;
  static inline synth::SynthSummary* summary_ = nullptr;
};

}  // namespace dome::capture::test_tapes
