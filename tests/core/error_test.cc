#include "core/error.h"

#include <gtest/gtest.h>

namespace dome::core {
namespace {

TEST(InputError, MessageNamesWhereAndWhat) {
  const InputError e("take/rig.json: cameras[2].focal_mm", "must be positive, got -1");
  EXPECT_STREQ(e.what(), "take/rig.json: cameras[2].focal_mm: must be positive, got -1");
  EXPECT_EQ(e.where(), "take/rig.json: cameras[2].focal_mm");
}

TEST(InputError, RequireThrowsOnlyWhenFalse) {
  EXPECT_NO_THROW(Require(true, "f", "x"));
  try {
    Require(false, "--threads", "expected a positive count");
    FAIL() << "no throw";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "--threads: expected a positive count");
  }
}

TEST(CheckDeathTest, AbortsWithExpression) {
  EXPECT_DEATH(DOME_CHECK(1 + 1 == 3, "arithmetic"), "check '1 \\+ 1 == 3' failed: arithmetic");
}

}  // namespace
}  // namespace dome::core
