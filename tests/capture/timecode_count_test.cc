#include "capture/timecode_count.h"

#include <gtest/gtest.h>

#include "testing/expect_error.h"

namespace dome::capture {
namespace {

using take::Timecode;

TEST(TimecodeCount, DropFrameSkipsTwoLabelsEachMinuteButTheTenth) {
  const auto df = VideoStandard::k525DropFrame;
  EXPECT_FALSE(IsValidLabel({0, 1, 0, 0}, df));
  EXPECT_FALSE(IsValidLabel({0, 1, 0, 1}, df));
  EXPECT_TRUE(IsValidLabel({0, 1, 0, 2}, df));
  EXPECT_TRUE(IsValidLabel({0, 10, 0, 0}, df));
  EXPECT_TRUE(IsValidLabel({0, 1, 0, 0}, VideoStandard::k525NonDrop));
  EXPECT_FALSE(IsValidLabel({0, 0, 0, 25}, VideoStandard::k625));
  // The frame after 00:00:59;29 is 00:01:00;02; after 00:09:59;29 comes 00:10:00;00.
  EXPECT_EQ(LabelOf(FrameNumber({0, 0, 59, 29}, df) + 1, df), (Timecode{0, 1, 0, 2}));
  EXPECT_EQ(LabelOf(FrameNumber({0, 9, 59, 29}, df) + 1, df), (Timecode{0, 10, 0, 0}));
  // Ten minutes are 17982 frames; an hour is 107892 (29.97 Hz x 3600 s, rounded).
  EXPECT_EQ(FrameNumber({0, 10, 0, 0}, df), 17982);
  EXPECT_EQ(FrameNumber({1, 0, 0, 0}, df), 107892);
  EXPECT_EQ(FramesPerDay(df), 24 * 107892);
}

TEST(TimecodeCount, LabelsAndNumbersRoundTripOverADay) {
  for (auto standard :
       {VideoStandard::k525NonDrop, VideoStandard::k525DropFrame, VideoStandard::k625}) {
    int64_t previous = -1;
    for (int64_t n = 0; n < FramesPerDay(standard); n += 997) {
      const Timecode tc = LabelOf(n, standard);
      ASSERT_TRUE(IsValidLabel(tc, standard)) << tc.Text() << " " << StandardName(standard);
      ASSERT_EQ(FrameNumber(tc, standard), n) << tc.Text();
      ASSERT_GT(n, previous);
      previous = n;
    }
    // Consecutive frames across every minute boundary of the first hour.
    for (int m = 0; m < 60; ++m) {
      const int64_t n = FrameNumber(
          {0, m, 0, standard == VideoStandard::k525DropFrame && m % 10 ? 2 : 0}, standard);
      if (n == 0) continue;
      const Timecode before = LabelOf(n - 1, standard);
      EXPECT_EQ(before.seconds, 59);
      EXPECT_EQ(before.frames, LabelsPerSecond(standard) - 1);
    }
  }
}

TEST(TimecodeCount, ParsesTextAndRanges) {
  const auto df = VideoStandard::k525DropFrame;
  EXPECT_EQ(ParseTimecode("01:02:03;04", df), (Timecode{1, 2, 3, 4}));
  EXPECT_EQ(ParseTimecode("01:02:03:04", VideoStandard::k625), (Timecode{1, 2, 3, 4}));
  EXPECT_FALSE(ParseTimecode("00:01:00;00", df));  // a skipped label
  EXPECT_FALSE(ParseTimecode("00:00:00:25", VideoStandard::k625));
  EXPECT_FALSE(ParseTimecode("0:00:00:00", df));
  const TimecodeRange r =
      ParseRange("00:00:10:00-00:00:11:20", VideoStandard::k525NonDrop, "--range");
  EXPECT_EQ(r.first, (Timecode{0, 0, 10, 0}));
  EXPECT_EQ(r.last, (Timecode{0, 0, 11, 20}));
  testing::ExpectInputError(
      [] { ParseRange("00:00:11:00-00:00:10:00", VideoStandard::k525NonDrop, "--range"); },
      {"--range", "after the last"});
  testing::ExpectInputError([] { ParseRange("garbage", VideoStandard::k625, "--range"); },
                            {"--range", "garbage", "HH:MM:SS:FF"});
}

}  // namespace
}  // namespace dome::capture
