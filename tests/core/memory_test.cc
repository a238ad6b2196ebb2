// Process memory settings (core/memory.h): transparent huge pages off unless asked for.
#include "core/memory.h"

#include <gtest/gtest.h>
#include <sys/prctl.h>

#include <cstdlib>

namespace dome::core {
namespace {

// The process flag the kernel reads when it places a fresh mapping's pages, and that
// the processes this one starts inherit.
int HugePagesOff() { return prctl(PR_GET_THP_DISABLE, 0, 0, 0, 0); }

TEST(Memory, TransparentHugePagesAreOffUnlessTheEnvironmentKeepsThem) {
  ASSERT_EQ(prctl(PR_SET_THP_DISABLE, 0, 0, 0, 0), 0);
  ASSERT_EQ(HugePagesOff(), 0);
  ::unsetenv("DOME_TRANSPARENT_HUGEPAGES");
  EXPECT_TRUE(AvoidTransparentHugePages());
  EXPECT_EQ(HugePagesOff(), 1);
  EXPECT_TRUE(AvoidTransparentHugePages());  // idempotent
  EXPECT_EQ(HugePagesOff(), 1);

  ASSERT_EQ(prctl(PR_SET_THP_DISABLE, 0, 0, 0, 0), 0);
  ::setenv("DOME_TRANSPARENT_HUGEPAGES", "1", 1);
  EXPECT_FALSE(AvoidTransparentHugePages());
  EXPECT_EQ(HugePagesOff(), 0);
  // Any other value is not a request to keep them.
  ::setenv("DOME_TRANSPARENT_HUGEPAGES", "yes", 1);
  EXPECT_TRUE(AvoidTransparentHugePages());
  EXPECT_EQ(HugePagesOff(), 1);
  ::unsetenv("DOME_TRANSPARENT_HUGEPAGES");
}

}  // namespace
}  // namespace dome::core
