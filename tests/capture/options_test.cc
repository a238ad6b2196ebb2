// Every options struct of the capture library checks itself and names the option at
// fault (not a command-line flag: the library does not know the commands).
#include <gtest/gtest.h>

#include "capture/digitizer.h"
#include "capture/pass_planner.h"
#include "capture/sony9pin.h"
#include "capture/tape.h"
#include "capture/vitc.h"
#include "testing/expect_error.h"

namespace dome::capture {
namespace {

using dome::testing::ExpectInputError;

TEST(CaptureOptions, EachCheckNamesTheOption) {
  EXPECT_NO_THROW(Sony9PinOptions{}.Check());
  ExpectInputError([] { Sony9PinOptions{.reply_timeout_ms = 0}.Check(); }, {"reply_timeout_ms"});
  ExpectInputError([] { Sony9PinOptions{.retries = 0}.Check(); }, {"retries"});
  EXPECT_NO_THROW(DeckEmulatorOptions{}.Check());
  ExpectInputError([] { DeckEmulatorOptions{.nak_first = -1}.Check(); }, {"nak_first"});

  EXPECT_NO_THROW(TapeLayout{}.Check());
  TapeLayout layout;
  layout.vitc_field_lines = {4, 12};
  ExpectInputError([&] { layout.Check(); }, {"vitc_field_lines", "line 12"});
  layout.vbi_field_lines = 0;
  ExpectInputError([&] { layout.Check(); }, {"vbi_field_lines"});

  EXPECT_NO_THROW(VitcLineOptions{}.Check());
  ExpectInputError([] { VitcLineOptions{.black_level = 200, .white_level = 100}.Check(); },
                   {"white_level", "above black_level"});
  EXPECT_NO_THROW(VitcDecoderOptions{}.Check());
  ExpectInputError([] { VitcDecoderOptions{.scale_tolerance = 0}.Check(); }, {"scale_tolerance"});
  ExpectInputError([] { VitcDecoderOptions{.first_row = 50, .last_row = 44}.Check(); },
                   {"first_row"});
  // The decoder refuses bad options when it is made, not at the first frame.
  ExpectInputError([] { VitcDecoder decoder(VitcDecoderOptions{.min_swing = 0}); }, {"min_swing"});

  ExpectInputError([] { SimDigitizerOptions{.keep_per_second = -1}.Check(); }, {"keep_per_second"});
  CaptureOptions capture;
  capture.range = ParseRange("00:00:10:00-00:00:11:00", VideoStandard::k525NonDrop, "range");
  EXPECT_NO_THROW(capture.Check());
  capture.every = 0;
  ExpectInputError([&] { capture.Check(); }, {"every"});
}

}  // namespace
}  // namespace dome::capture
