// The process-wide store of values built once (pipeline/once_store.h): concurrent
// callers of one key share one build and one value; a failed build's error reaches
// those that waited and is not kept; the oldest keys go beyond the capacity. The process's
// worker threads (shared_hulls.h), and the idle ones lent to the stages that end an instant.
#include "pipeline/once_store.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <stdexcept>
#include <thread>
#include <vector>

#include "core/parallel_for.h"
#include "pipeline/shared_hulls.h"
#include "pipeline/stage.h"

namespace dome::pipeline {
namespace {

TEST(OnceStore, CallersOfOneKeyShareOneBuild) {
  OnceStore<int> store(2);
  std::atomic<int> built{0};
  std::promise<void> release;
  std::shared_future<void> go = release.get_future().share();
  auto slow = [&] {
    ++built;
    go.wait();  // the others ask while this build runs
    return std::make_unique<int>(7);
  };
  std::vector<std::shared_ptr<const int>> got(4);
  std::vector<std::thread> threads;
  for (size_t i = 0; i < got.size(); ++i)
    threads.emplace_back([&, i] { got[i] = store.Get("a", slow); });
  while (store.builds() == 0) std::this_thread::yield();
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  release.set_value();
  for (auto& t : threads) t.join();
  EXPECT_EQ(built.load(), 1);
  for (const auto& v : got) {
    ASSERT_TRUE(v);
    EXPECT_EQ(v.get(), got[0].get());
    EXPECT_EQ(*v, 7);
  }
  // Kept: asked again, not built again.
  EXPECT_EQ(store.Get("a", slow).get(), got[0].get());
  EXPECT_EQ(built.load(), 1);
}

TEST(OnceStore, AFailedBuildReachesItsWaitersAndIsNotKept) {
  OnceStore<int> store(2);
  std::promise<void> release;
  std::shared_future<void> go = release.get_future().share();
  std::thread builder([&] {
    EXPECT_THROW(store.Get("k",
                           [&]() -> std::unique_ptr<int> {
                             go.wait();
                             throw std::runtime_error("bad mask");
                           }),
                 std::runtime_error);
  });
  while (store.builds() == 0) std::this_thread::yield();
  std::string waiter_error;
  std::thread waiter([&] {
    try {
      store.Get("k", [] { return std::make_unique<int>(1); });
    } catch (const std::runtime_error& e) {
      waiter_error = e.what();
    }
  });
  // Time for the waiter to reach the store and wait (it would build its own after).
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  release.set_value();
  builder.join();
  waiter.join();
  EXPECT_EQ(waiter_error, "bad mask");
  // A later call builds again.
  EXPECT_EQ(*store.Get("k", [] { return std::make_unique<int>(3); }), 3);
  EXPECT_EQ(store.builds(), 2);
}

TEST(OnceStore, TheOldestKeysGoBeyondTheCapacity) {
  OnceStore<int> store(2);
  int n = 0;
  auto make = [&] { return std::make_unique<int>(++n); };
  const auto a = store.Get("a", make);
  store.Get("b", make);
  store.Get("c", make);  // drops "a"
  EXPECT_EQ(*store.Get("b", make), 2);
  EXPECT_EQ(*store.Get("a", make), 4);  // built again
  EXPECT_EQ(*a, 1);                     // a holder's value stays
  EXPECT_EQ(store.builds(), 4);
}

// The process's worker threads (shared_hulls.h), which a shared hull is built with: each
// worker's own while it lives, none below zero.
TEST(WorkerThreads, CountTheWorkersThreadsWhileTheyLive) {
  const int before = ProcessWorkerThreads();
  {
    WorkerThreads a(1);
    EXPECT_EQ(ProcessWorkerThreads(), before + 1);
    {
      WorkerThreads b(3);
      WorkerThreads none(-2);  // a worker's threads are never negative
      EXPECT_EQ(ProcessWorkerThreads(), before + 4);
    }
    EXPECT_EQ(ProcessWorkerThreads(), before + 1);
  }
  EXPECT_EQ(ProcessWorkerThreads(), before);
}

TEST(WorkerThreads, IdleWorkersLendTheirThreadsToTheStagesThatEndAnInstant) {
  ASSERT_EQ(IdleWorkerThreads(), 0);
  const int hardware = core::HardwareThreads();
  WorkerThreads running(1), waiting(1);
  EXPECT_EQ(LentThreads(1), 1);  // nobody idle
  waiting.SetIdle(true);
  waiting.SetIdle(true);  // counted once
  EXPECT_EQ(IdleWorkerThreads(), 1);
  EXPECT_EQ(LentThreads(1), std::min(2, std::max(1, hardware)));
  // Never beyond the machine's threads, never below the worker's own.
  EXPECT_EQ(LentThreads(hardware), hardware);
  EXPECT_EQ(LentThreads(hardware + 3), hardware + 3);
  waiting.SetIdle(false);
  EXPECT_EQ(LentThreads(1), 1);
  {
    WorkerThreads gone(2);
    gone.SetIdle(true);
    EXPECT_EQ(IdleWorkerThreads(), 2);
  }
  EXPECT_EQ(IdleWorkerThreads(), 0);  // a worker that ends idle lends nothing
  // The stages that end an instant borrow; the many-part ones keep their own (their
  // hulls and tables are keyed by it).
  const auto stages = DefaultStages();
  for (const auto& d : stages->stages) {
    EXPECT_EQ(d.borrows_idle_threads, d.name == "decimate" || d.name == "texture") << d.name;
  }
  EXPECT_GE(stages->Find("stereo"), 0);
  EXPECT_GE(stages->Find("fusion"), 0);
}

}  // namespace
}  // namespace dome::pipeline
