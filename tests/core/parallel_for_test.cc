#include "core/parallel_for.h"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

namespace dome::core {
namespace {

TEST(ParallelFor, VisitsEveryIndexExactlyOnce) {
  for (int threads : {1, 2, 3, 7, 64}) {
    std::vector<std::atomic<int>> hits(1000);
    ParallelFor(0, 1000, threads, [&](int64_t b, int64_t e) {
      for (int64_t i = b; i < e; ++i) hits[i]++;
    });
    for (int i = 0; i < 1000; ++i)
      ASSERT_EQ(hits[i].load(), 1) << "index " << i << " threads " << threads;
  }
}

TEST(ParallelFor, EmptyRangeCallsNothing) {
  int calls = 0;
  ParallelFor(5, 5, 4, [&](int64_t, int64_t) { ++calls; });
  EXPECT_EQ(calls, 0);
}

TEST(ParallelFor, RethrowsWorkerException) {
  EXPECT_THROW(ParallelFor(0, 100, 4,
                           [](int64_t b, int64_t) {
                             if (b > 0) throw std::runtime_error("chunk failed");
                           }),
               std::runtime_error);
}

}  // namespace
}  // namespace dome::core
