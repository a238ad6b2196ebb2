#include "capture/sony9pin.h"

#include <gtest/gtest.h>

#include "capture/sim_deck.h"
#include "tape_fixture.h"
#include "testing/expect_error.h"

namespace dome::capture {
namespace {

using take::Timecode;

TEST(Sony9Pin, BlocksCarryCountAndChecksum) {
  const auto play = Sony9PinBlock{0x20, 0x01, {}}.Encode();
  EXPECT_EQ(play, (std::vector<uint8_t>{0x20, 0x01, 0x21}));
  const auto cue = Sony9PinBlock{0x20, 0x31, EncodeTimeData({1, 23, 45, 29}, true)}.Encode();
  EXPECT_EQ(cue,
            (std::vector<uint8_t>{0x24, 0x31, 0x69, 0x45, 0x23, 0x01,
                                  static_cast<uint8_t>(0x24 + 0x31 + 0x69 + 0x45 + 0x23 + 0x01)}));
  EXPECT_EQ(DecodeTimeData(cue.data() + 2), (Timecode{1, 23, 45, 29}));
  const uint8_t bad[4] = {0x1A, 0, 0, 0};
  EXPECT_FALSE(DecodeTimeData(bad));
  EXPECT_EQ(NakText(0x14), "checksum error, parity error");
}

class Sony9PinDeckTest : public ::testing::Test {
 protected:
  Sony9PinDeckTest()
      : sim_(test_tapes::MakeTape(test_tapes::Consecutive(300, 40), layout_), layout_, "sim:test") {
  }
  TapeLayout layout_;
  SimDeck sim_;
};

TEST_F(Sony9PinDeckTest, PlayCueAndSenseRoundTripsOverAPseudoTerminal) {
  DeckEmulator emulator(&sim_);
  emulator.Start();
  Sony9PinDeck deck(emulator.device_path());
  EXPECT_EQ(deck.Name(), "serial:" + emulator.device_path());
  deck.CueUpWithData({0, 0, 10, 12});
  DeckStatus status = deck.Status();
  EXPECT_TRUE(status.cue_complete);
  EXPECT_EQ(status.transport, Transport::kStopped);
  EXPECT_EQ(deck.CurrentTime(), (Timecode{0, 0, 10, 12}));
  deck.Play();
  EXPECT_EQ(deck.Status().transport, Transport::kPlaying);
  cv::Mat frame;
  double t = 0;
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(sim_.NextFrame(&frame, &t));
  EXPECT_EQ(deck.CurrentTime(), (Timecode{0, 0, 10, 17}));
  deck.Stop();
  EXPECT_EQ(deck.Status().transport, Transport::kStopped);
  EXPECT_FALSE(sim_.NextFrame(&frame, &t));
  deck.Rewind();
  EXPECT_EQ(deck.CurrentTime(), (Timecode{0, 0, 10, 0}));
  deck.FastForward();
  EXPECT_EQ(deck.CurrentTime(), (Timecode{0, 0, 11, 9}));
  EXPECT_EQ(emulator.commands_seen(), 12);  // one block each, no retries
}

TEST_F(Sony9PinDeckTest, RecoverableNaksAreRetried) {
  DeckEmulator emulator(&sim_, {.nak_first = 2});
  emulator.Start();
  Sony9PinDeck deck(emulator.device_path());
  deck.CueUpWithData({0, 0, 10, 20});  // NAK, NAK, ACK
  EXPECT_EQ(emulator.commands_seen(), 3);
  EXPECT_EQ(deck.CurrentTime(), (Timecode{0, 0, 10, 20}));
}

TEST_F(Sony9PinDeckTest, ANakingDeckGivesAClearError) {
  DeckEmulator emulator(&sim_, {.nak_everything = true});
  emulator.Start();
  Sony9PinDeck deck(emulator.device_path());
  dome::testing::ExpectInputError([&] { deck.Play(); }, {"serial:" + emulator.device_path(), "PLAY",
                                                         "NAK", "undefined command"});
}

TEST_F(Sony9PinDeckTest, ASilentDeckTimesOutWithAClearError) {
  DeckEmulator emulator(&sim_, {.silent_after = 1});
  emulator.Start();
  Sony9PinDeck deck(emulator.device_path(), {.reply_timeout_ms = 30});
  deck.Stop();  // answered
  dome::testing::ExpectInputError([&] { deck.CurrentTime(); },
                                  {"serial:" + emulator.device_path(), "CURRENT TIME SENSE",
                                   "3 tries", "no reply within 30 ms"});
  EXPECT_EQ(emulator.commands_seen(), 4);
}

TEST(Sony9PinPort, MissingDeviceIsNamed) {
  dome::testing::ExpectInputError([] { Sony9PinDeck deck("/dev/does-not-exist"); },
                                  {"serial:/dev/does-not-exist", "cannot open"});
}

}  // namespace
}  // namespace dome::capture
