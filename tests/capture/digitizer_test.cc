#include "capture/digitizer.h"

#include <gtest/gtest.h>

#include "capture/sim_deck.h"
#include "tape_fixture.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::capture {
namespace {

TEST(Digitizer, FileDigitizerDeliversTheTapeFramesWithTheirVerticalInterval) {
  dome::testing::TempDir dir;
  TapeLayout layout;
  const auto frames = test_tapes::MakeTape(test_tapes::Consecutive(300, 12), layout);
  {
    TapeWriter writer(dir / "tape.avi", frames[0].size(), layout.standard);
    for (const auto& f : frames) writer.Write(f);
  }
  OpenCvDigitizer digitizer("file:" + dir.File("tape.avi"));
  const VitcDecoder decoder(layout.DecoderOptions());
  cv::Mat frame, kept;
  int n = 0;
  while (digitizer.Next(&frame)) {
    ASSERT_LT(n, 12);
    EXPECT_EQ(cv::countNonZero(frame != frames[n]), 0) << "frame " << n << " is not lossless";
    const auto vitc = decoder.ReadFirst(frame);
    ASSERT_TRUE(vitc);
    EXPECT_EQ(FrameNumber(vitc->word.time, layout.standard), 300 + n);
    ASSERT_TRUE(digitizer.Keep(&kept));
    EXPECT_EQ(cv::countNonZero(kept != frames[n]), 0);
    ++n;
  }
  EXPECT_EQ(n, 12);
  dome::testing::ExpectInputError([&] { OpenCvDigitizer bad("file:" + dir.File("missing.avi")); },
                                  {"missing.avi", "no such video file"});
  dome::testing::ExpectInputError([] { OpenCvDigitizer bad("camera0"); },
                                  {"camera0", "v4l2:/dev/videoN"});
}

TEST(Digitizer, SimDigitizerKeepsAtMostItsBandwidth) {
  TapeLayout layout;
  SimDeck deck(test_tapes::MakeTape(test_tapes::Consecutive(300, 90), layout), layout, "sim:test");
  SimDigitizer digitizer(&deck, {.keep_per_second = 10.0});
  deck.CueUpWithData({0, 0, 10, 0});
  deck.Play();
  cv::Mat frame, kept;
  std::vector<int> kept_at;
  for (int i = 0; digitizer.Next(&frame); ++i) {
    if (digitizer.Keep(&kept)) kept_at.push_back(i);
  }
  ASSERT_EQ(kept_at.size(), 30u);  // 3 s of 29.97 Hz signal at 10 frames/s
  for (size_t k = 1; k < kept_at.size(); ++k) EXPECT_EQ(kept_at[k] - kept_at[k - 1], 3);
  dome::testing::ExpectInputError([&] { SimDigitizer bad(&deck, {.drop_probability = 1.5}); },
                                  {"drop_probability", "[0, 1)"});
}

}  // namespace
}  // namespace dome::capture
