// A thread-safe store of values built once per key for all of a process's workers: the
// first caller for a key builds the value; callers asking meanwhile wait for it and take
// the same one. The latest `capacity` keys are kept (the oldest dropped first; a caller
// waiting on a dropped key still gets its value). A failed build is not kept: its error
// reaches every caller that waited for it, and a later call builds again.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>

namespace dome::pipeline {

template <class T>
class OnceStore {
 public:
  explicit OnceStore(size_t capacity) : capacity_(capacity) {}

  std::shared_ptr<const T> Get(const std::string& key,
                               const std::function<std::unique_ptr<T>()>& build) {
    std::promise<std::shared_ptr<const T>> promise;
    std::optional<std::shared_future<std::shared_ptr<const T>>> theirs;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (const auto& [k, future] : held_) {
        if (k == key) theirs = future;
      }
      if (!theirs) {
        held_.emplace_back(key, promise.get_future().share());
        while (held_.size() > capacity_) held_.pop_front();
        ++builds_;
      }
    }
    // Waited for outside the lock: other keys' callers go on meanwhile.
    if (theirs) return theirs->get();  // rethrows the builder's error
    try {
      std::shared_ptr<const T> value(build());
      promise.set_value(value);
      return value;
    } catch (...) {
      promise.set_exception(std::current_exception());
      std::lock_guard<std::mutex> lock(mutex_);
      for (auto it = held_.begin(); it != held_.end(); ++it) {
        // This key's failed build (a kept value for the key would have been found).
        if (it->first == key &&
            it->second.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
          held_.erase(it);
          break;
        }
      }
      throw;
    }
  }

  // Builds run so far, and dropping every value kept.
  int64_t builds() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return builds_;
  }
  void Clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    held_.clear();
  }

 private:
  const size_t capacity_;
  mutable std::mutex mutex_;
  // Oldest first; a value being built is held as the future its builder will set.
  std::deque<std::pair<std::string, std::shared_future<std::shared_ptr<const T>>>> held_;
  int64_t builds_ = 0;
};

}  // namespace dome::pipeline
