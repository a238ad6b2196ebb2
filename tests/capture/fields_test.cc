// The take image made from a synthetic tape is the synthetic take's image, pixel for
// pixel; and the tape carries each instant's VITC.
#include "capture/fields.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "capture/sim_deck.h"
#include "io/image_io.h"
#include "synth/synth.h"
#include "take/timecode.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::capture {
namespace {

TEST(Fields, SplitAndAverage) {
  cv::Mat frame(4, 4, CV_8UC1);
  for (int i = 0; i < 16; ++i) frame.data[i] = static_cast<uint8_t>(i * 10);
  const cv::Mat even = ExtractField(frame, 0), odd = ExtractField(frame, 1);
  ASSERT_EQ(even.rows, 2);
  EXPECT_EQ(even.at<uint8_t>(1, 0), 80);
  EXPECT_EQ(odd.at<uint8_t>(0, 3), 70);
  const cv::Mat half = AverageColumnPairs(even);
  ASSERT_EQ(half.cols, 2);
  EXPECT_EQ(half.at<uint8_t>(0, 0), 5);    // (0 + 10 + 1) / 2
  EXPECT_EQ(half.at<uint8_t>(1, 1), 105);  // (100 + 110 + 1) / 2
}

TEST(Fields, SynthTapesGiveTheTakeImagesPixelForPixel) {
  dome::testing::TempDir dir;
  synth::SynthOptions options;
  options.preset = "small";
  options.write_calibration = false;
  options.write_tape_video = true;
  const synth::SynthSummary summary = synth::GenerateTake(options, dir.path());
  const TapeLayout layout;
  int compared = 0;
  std::vector<std::filesystem::path> tapes;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path() / "tape")) {
    if (entry.path().extension() == ".avi") tapes.push_back(entry.path());
  }
  std::sort(tapes.begin(), tapes.end());
  ASSERT_EQ(static_cast<int>(tapes.size()), summary.scene.cameras);
  for (const auto& tape : tapes) {
    const std::string id = tape.stem().string();
    const std::vector<cv::Mat> frames = ReadTapeFrames(tape);
    ASSERT_EQ(static_cast<int>(frames.size()), summary.scene.instants);
    const VitcDecoder decoder(layout.DecoderOptions());
    for (int k = 0; k < summary.scene.instants; ++k) {
      EXPECT_EQ(frames[k].cols, 2 * summary.scene.width_px);
      EXPECT_EQ(frames[k].rows, 2 * summary.scene.height_px + layout.VbiRows());
      const auto reads = decoder.ReadAll(frames[k]);
      ASSERT_EQ(reads.size(), 4u) << "two VITC lines in each field";
      EXPECT_EQ(reads[0].word.time, *take::ParseInstantName(summary.instants[k]));
      EXPECT_FALSE(reads[0].word.field_mark);
      EXPECT_TRUE(reads[1].word.field_mark);
      const cv::Mat image = TakeImage(frames[k], layout, {}, tape.string());
      const cv::Mat truth = io::ReadImage(
          dir.path() / "frames" / summary.instants[k] / (id + ".png"), io::ImageMode::kGray8);
      ASSERT_EQ(image.size(), truth.size());
      EXPECT_EQ(cv::countNonZero(image != truth), 0) << id << " " << summary.instants[k];
      ++compared;
    }
  }
  EXPECT_EQ(compared, summary.scene.cameras * summary.scene.instants);
  // The other field order contradicts the field marks.
  FieldOptions wrong;
  wrong.upper_field_first = false;
  const auto frames = ReadTapeFrames(tapes[0]);
  dome::testing::ExpectInputError([&] { TakeImage(frames[0], layout, wrong, "first tape"); },
                                  {"first tape", "field mark 1"});
}

}  // namespace
}  // namespace dome::capture
