#include "capture/pass_planner.h"

#include <gtest/gtest.h>

#include <map>

#include "capture/sim_deck.h"
#include "capture/sony9pin.h"
#include "tape_fixture.h"
#include "testing/expect_error.h"

namespace dome::capture {
namespace {

using test_tapes::Consecutive;
using test_tapes::ExpectedTakeImage;
using test_tapes::MakeTape;

// Every frame the sink got, by frame number, with a check that none came twice and
// each image is the right one.
struct Collector {
  VideoStandard standard = VideoStandard::k525NonDrop;
  std::map<int64_t, int> times;
  int wrong_pixels = 0;
  FrameSink Sink() {
    return [this](const CapturedFrame& f) {
      const int64_t n = FrameNumber(f.time, standard);
      ++times[n];
      const cv::Mat want = ExpectedTakeImage(n);
      if (f.take_image.size() != want.size() || cv::countNonZero(f.take_image != want) != 0)
        ++wrong_pixels;
    };
  }
  int Duplicates() const {
    int d = 0;
    for (const auto& [n, count] : times) d += count - 1;
    return d;
  }
};

CaptureOptions Options(const std::string& range) {
  CaptureOptions options;
  options.range = ParseRange(range, VideoStandard::k525NonDrop, "range");
  options.preroll_frames = 10;
  return options;
}

// 00:00:10:00 is frame 300; the tape runs from 00:00:09:00 for four seconds.
constexpr int64_t kTapeStart = 270;
constexpr int kTapeFrames = 120;

TEST(PassPlanner, OnePassWhenTheDigitizerKeepsEveryFrame) {
  TapeLayout layout;
  SimDeck deck(MakeTape(Consecutive(kTapeStart, kTapeFrames), layout), layout, "sim:test");
  SimDigitizer digitizer(&deck, {});
  PassPlanner planner(&deck, &digitizer, Options("00:00:10:00-00:00:11:29"));
  Collector got;
  const CaptureSummary summary = planner.Run(got.Sink());
  EXPECT_TRUE(summary.complete()) << summary.BriefReport();
  EXPECT_EQ(summary.wanted, 60);
  ASSERT_EQ(summary.passes.size(), 1u);
  EXPECT_EQ(summary.passes[0].new_frames, 60);
  EXPECT_EQ(summary.passes[0].cued_to, (take::Timecode{0, 0, 9, 20}));
  EXPECT_EQ(got.times.size(), 60u);
  EXPECT_EQ(got.times.begin()->first, 300);
  EXPECT_EQ(got.times.rbegin()->first, 359);
  EXPECT_EQ(got.Duplicates(), 0);
  EXPECT_EQ(got.wrong_pixels, 0);
}

TEST(PassPlanner, ADigitizerKeepingOneFrameInThreeNeedsThreePasses) {
  TapeLayout layout;
  SimDeck deck(MakeTape(Consecutive(kTapeStart, kTapeFrames), layout), layout, "sim:test");
  SimDigitizer digitizer(&deck, {.keep_per_second = 10.0});
  PassPlanner planner(&deck, &digitizer, Options("00:00:10:00-00:00:11:29"));
  Collector got;
  const CaptureSummary summary = planner.Run(got.Sink());
  EXPECT_TRUE(summary.complete()) << summary.BriefReport();
  ASSERT_EQ(summary.passes.size(), 3u) << summary.BriefReport();
  for (const auto& pass : summary.passes) EXPECT_EQ(pass.new_frames, 20) << summary.BriefReport();
  EXPECT_EQ(got.times.size(), 60u);
  EXPECT_EQ(got.Duplicates(), 0);
  EXPECT_EQ(got.wrong_pixels, 0);
}

TEST(PassPlanner, RandomDropsCostACleanUpPass) {
  TapeLayout layout;
  SimDeck deck(MakeTape(Consecutive(kTapeStart, kTapeFrames), layout), layout, "sim:test");
  SimDigitizer digitizer(&deck, {.keep_per_second = 10.0, .drop_probability = 0.05, .seed = 4});
  PassPlanner planner(&deck, &digitizer, Options("00:00:10:00-00:00:11:29"));
  Collector got;
  const CaptureSummary summary = planner.Run(got.Sink());
  EXPECT_TRUE(summary.complete()) << summary.BriefReport();
  EXPECT_GE(summary.passes.size(), 4u) << summary.BriefReport();
  EXPECT_LE(summary.passes.size(), 6u) << summary.BriefReport();
  EXPECT_GT(digitizer.dropped(), 0);
  EXPECT_EQ(got.times.size(), 60u);
  EXPECT_EQ(got.Duplicates(), 0);
  EXPECT_EQ(got.wrong_pixels, 0);
}

TEST(PassPlanner, EveryFifthFrameAsTheSeedDigitized) {
  TapeLayout layout;
  SimDeck deck(MakeTape(Consecutive(kTapeStart, kTapeFrames), layout), layout, "sim:test");
  SimDigitizer digitizer(&deck, {});
  CaptureOptions options = Options("00:00:10:00-00:00:11:25");
  options.every = 5;
  PassPlanner planner(&deck, &digitizer, options);
  Collector got;
  const CaptureSummary summary = planner.Run(got.Sink());
  EXPECT_TRUE(summary.complete());
  ASSERT_EQ(got.times.size(), 12u);
  for (const auto& [n, count] : got.times) EXPECT_EQ((n - 300) % 5, 0);
}

TEST(PassPlanner, FramesWithoutVitcAreNeverGuessedAndReportedMissing) {
  TapeLayout layout;
  const std::vector<int64_t> blank = {310, 311, 312, 313, 314};
  SimDeck deck(MakeTape(Consecutive(kTapeStart, kTapeFrames), layout, blank), layout, "sim:test");
  SimDigitizer digitizer(&deck, {});
  PassPlanner planner(&deck, &digitizer, Options("00:00:10:00-00:00:10:29"));
  Collector got;
  const CaptureSummary summary = planner.Run(got.Sink());
  EXPECT_FALSE(summary.complete());
  EXPECT_EQ(summary.captured, 25);
  ASSERT_EQ(summary.missing.size(), 5u) << summary.BriefReport();
  for (size_t i = 0; i < blank.size(); ++i)
    EXPECT_EQ(summary.missing[i], LabelOf(blank[i], layout.standard));
  for (int64_t n : blank) EXPECT_EQ(got.times.count(n), 0u);
  EXPECT_GE(summary.passes[0].unreadable, 5);
  EXPECT_EQ(got.Duplicates(), 0);
  EXPECT_EQ(got.wrong_pixels, 0);
  // Passes stop once they bring nothing new, rather than running to the pass limit.
  EXPECT_EQ(summary.passes.size(), 3u) << summary.BriefReport();
}

TEST(PassPlanner, RepeatedAndOutOfOrderFramesAreCapturedOnceWithTheirOwnPictures) {
  TapeLayout layout;
  std::vector<int64_t> order = Consecutive(kTapeStart, 30);
  for (int64_t n : {300, 301, 303, 302, 302, 304, 301, 305, 306, 308, 307, 309}) order.push_back(n);
  for (int64_t n = 310; n < 330; ++n) order.push_back(n);
  SimDeck deck(MakeTape(order, layout), layout, "sim:test");
  SimDigitizer digitizer(&deck, {});
  PassPlanner planner(&deck, &digitizer, Options("00:00:10:00-00:00:10:19"));
  Collector got;
  const CaptureSummary summary = planner.Run(got.Sink());
  EXPECT_TRUE(summary.complete()) << summary.BriefReport();
  EXPECT_EQ(got.times.size(), 20u);
  EXPECT_EQ(got.Duplicates(), 0);
  EXPECT_EQ(got.wrong_pixels, 0);
  EXPECT_GE(summary.passes[0].out_of_order, 3);
  EXPECT_GE(summary.passes[0].repeats, 2);
}

TEST(PassPlanner, SerialDeckWithNaksCompletesAndASilentOneFailsClearly) {
  TapeLayout layout;
  SimDeck sim(MakeTape(Consecutive(kTapeStart, kTapeFrames), layout), layout, "sim:test");
  {
    DeckEmulator emulator(&sim, {.nak_first = 2});
    emulator.Start();
    Sony9PinDeck deck(emulator.device_path());
    SimDigitizer digitizer(&sim, {.keep_per_second = 10.0});
    PassPlanner planner(&deck, &digitizer, Options("00:00:10:00-00:00:10:29"));
    Collector got;
    const CaptureSummary summary = planner.Run(got.Sink());
    EXPECT_TRUE(summary.complete()) << summary.BriefReport();
    EXPECT_EQ(summary.passes.size(), 3u);
    EXPECT_EQ(got.Duplicates(), 0);
    EXPECT_EQ(got.wrong_pixels, 0);
  }
  {
    DeckEmulator emulator(&sim, {.silent_after = 0});
    emulator.Start();
    Sony9PinDeck deck(emulator.device_path(), {.reply_timeout_ms = 20});
    SimDigitizer digitizer(&sim, {});
    PassPlanner planner(&deck, &digitizer, Options("00:00:10:00-00:00:10:29"));
    Collector got;
    dome::testing::ExpectInputError([&] { planner.Run(got.Sink()); },
                                    {"serial:" + emulator.device_path(), "gave up after 3 passes",
                                     "CUE UP WITH DATA", "no reply"});
    EXPECT_TRUE(got.times.empty());
  }
}

TEST(PassPlanner, DropFrameRangeAcrossAMinuteSkipsTheDroppedLabels) {
  TapeLayout layout;
  layout.standard = VideoStandard::k525DropFrame;
  const int64_t minute =
      FrameNumber({0, 1, 0, 2}, layout.standard);  // 00:01:00;02 follows 00:00:59;29
  SimDeck deck(MakeTape(Consecutive(minute - 40, 80), layout), layout, "sim:test");
  SimDigitizer digitizer(&deck, {.keep_per_second = 10.0});
  CaptureOptions options;
  options.layout = layout;
  options.range = ParseRange("00:00:59;20-00:01:00;09", layout.standard, "range");
  options.preroll_frames = 10;
  PassPlanner planner(&deck, &digitizer, options);
  Collector got;
  got.standard = layout.standard;
  const CaptureSummary summary = planner.Run(got.Sink());
  EXPECT_TRUE(summary.complete()) << summary.BriefReport();
  EXPECT_EQ(summary.wanted, 18);  // 10 frames of second 59, then ;02 .. ;09
  EXPECT_EQ(got.times.size(), 18u);
  EXPECT_EQ(got.Duplicates(), 0);
  EXPECT_EQ(got.wrong_pixels, 0);
}

TEST(PassPlanner, FieldOrderIsCheckedAgainstTheFieldMark) {
  TapeLayout layout;
  SimDeck deck(MakeTape(Consecutive(kTapeStart, kTapeFrames), layout), layout, "sim:test");
  SimDigitizer digitizer(&deck, {});
  CaptureOptions options = Options("00:00:10:00-00:00:10:09");
  options.fields.upper_field_first = false;
  PassPlanner planner(&deck, &digitizer, options);
  Collector got;
  dome::testing::ExpectInputError([&] { planner.Run(got.Sink()); },
                                  {"field mark 1", "field order"});
}

}  // namespace
}  // namespace dome::capture
