// Work handed off the master's loop to a pool of threads (master/master.h): checking,
// hashing and writing a result's files.
#pragma once

#include <spdlog/spdlog.h>

#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace dome::scheduler {

// Work handed off the loop (checking, hashing and writing a result's files) to a pool
// of threads, started in the order posted. Each piece of work returns what the loop
// does with its outcome; Collect() runs those on the loop's thread, in the order they
// finished (results are independent; two results of one job are told apart by the
// loop). Work still queued when the master stops is dropped (its results were never
// journalled: they are redone).
class Offload {
 public:
  using Work = std::function<std::function<void()>()>;
  explicit Offload(int threads) {
    for (int t = 0; t < threads; ++t) threads_.emplace_back([this] { Loop(); });
  }
  ~Offload() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    for (auto& t : threads_) t.join();
  }
  void Post(Work work) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      queue_.push_back(std::move(work));
      ++pending_;
    }
    cv_.notify_one();
  }
  // Runs the completions of the work finished so far (on the caller's thread).
  void Collect() {
    std::deque<std::function<void()>> done;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done.swap(done_);
      pending_ -= int(done.size());
    }
    for (auto& then : done) {
      try {
        then();
      } catch (const std::exception& e) {
        spdlog::error("master: acting on work done beside the loop failed: {}", e.what());
      }
    }
  }
  // Work posted whose completion has not been collected.
  int pending() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return pending_;
  }

 private:
  void Loop() {
    while (true) {
      Work work;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
        if (stop_) return;
        work = std::move(queue_.front());
        queue_.pop_front();
      }
      std::function<void()> then;
      try {
        then = work();
      } catch (const std::exception& e) {
        // Work reports its own errors; this is a bug or the file system failing.
        then = [what = std::string(e.what())] {
          spdlog::error("master: work beside the loop failed: {}", what);
        };
      }
      std::lock_guard<std::mutex> lock(mutex_);
      done_.push_back(std::move(then));
    }
  }

  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Work> queue_;
  std::deque<std::function<void()>> done_;
  int pending_ = 0;
  bool stop_ = false;
  std::vector<std::thread> threads_;  // last: they start after the members they use
};

}  // namespace dome::scheduler
