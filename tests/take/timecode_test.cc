#include "take/timecode.h"

#include <gtest/gtest.h>

namespace dome::take {
namespace {

TEST(Timecode, FolderNameRoundTrip) {
  const Timecode tc{1, 2, 3, 29};
  EXPECT_EQ(tc.FolderName(), "01-02-03-29");
  EXPECT_EQ(tc.Text(), "01:02:03:29");
  EXPECT_EQ(tc.Text(true), "01:02:03;29");
  EXPECT_EQ(ParseInstantName("01-02-03-29"), tc);
}

TEST(Timecode, RejectsMalformedNames) {
  for (const char* bad : {"", "01-02-03", "01:02:03:04", "24-00-00-00", "00-60-00-00",
                          "00-00-60-00", "00-00-00-30", "0a-00-00-00", "00-00-00-000"}) {
    EXPECT_FALSE(ParseInstantName(bad).has_value()) << bad;
  }
}

TEST(Timecode, FolderNamesSortInTimeOrder) {
  EXPECT_LT(Timecode({0, 0, 9, 29}).FolderName(), Timecode({0, 0, 10, 0}).FolderName());
  EXPECT_LT(Timecode({0, 0, 9, 29}), Timecode({0, 0, 10, 0}));
}

}  // namespace
}  // namespace dome::take
