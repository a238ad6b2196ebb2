#include "core/wake_pipe.h"

#include <gtest/gtest.h>
#include <poll.h>

#include <thread>

namespace dome::core {
namespace {

// Whether the pipe's read end is readable now (poll without waiting).
bool Readable(const WakePipe& pipe) {
  pollfd p{pipe.read_fd(), POLLIN, 0};
  return ::poll(&p, 1, 0) == 1 && (p.revents & POLLIN) != 0;
}

TEST(WakePipe, AWakeMakesItReadableUntilDrained) {
  WakePipe pipe("test");
  EXPECT_FALSE(Readable(pipe));
  pipe.Wake();
  pipe.Wake();  // two wakes before a drain: one drain clears both
  EXPECT_TRUE(Readable(pipe));
  pipe.Drain();
  EXPECT_FALSE(Readable(pipe));
  pipe.Drain();  // nothing to drain: returns at once (non-blocking)
  EXPECT_FALSE(Readable(pipe));
}

TEST(WakePipe, AnotherThreadsWakeEndsABlockingPoll) {
  WakePipe pipe("test");
  int ready = 0;
  std::thread poller([&] {
    pollfd p{pipe.read_fd(), POLLIN, 0};
    ready = ::poll(&p, 1, 30000);  // ends at the wake; 0 (a failure) after 30 s without
  });
  pipe.Wake();
  poller.join();
  EXPECT_EQ(ready, 1);
}

TEST(WakePipe, WakesBeyondThePipesCapacityAreDroppedNotBlocking) {
  WakePipe pipe("test");
  for (int i = 0; i < 1 << 20; ++i) pipe.Wake();  // a pipe holds 64 KiB: the rest drop
  EXPECT_TRUE(Readable(pipe));
  pipe.Drain();
  EXPECT_FALSE(Readable(pipe));
}

}  // namespace
}  // namespace dome::core
