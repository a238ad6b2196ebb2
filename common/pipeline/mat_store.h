// A process-wide store of images under string keys, bounded in bytes (the oldest dropped
// first), for images made once and used by several jobs of this process's workers:
// decoded frames handed over (frame_handoff.h), frames' ideal greys (ideal_greys.h).
// Thread-safe.
#pragma once

#include <deque>
#include <mutex>
#include <opencv2/core.hpp>
#include <string>

namespace dome::pipeline {

class MatStore {
 public:
  explicit MatStore(size_t budget_bytes) : budget_(budget_bytes) {}

  // Keeps `image` under `key` unless the key is held already (the same key, the same
  // image) or the image alone is over the budget; returns the image held under the key
  // (`image` or the one held before).
  cv::Mat Put(const std::string& key, const cv::Mat& image) {
    if (image.empty() || Bytes(image) > budget_) return image;
    std::lock_guard<std::mutex> lock(mutex_);
    for (const Held& h : held_)
      if (h.key == key) return h.image;
    held_.push_back({key, image});
    bytes_ += Bytes(image);
    while (bytes_ > budget_) {
      bytes_ -= Bytes(held_.front().image);
      held_.pop_front();
    }
    return image;
  }
  // The image under `key`, kept (Find) or removed (Take); empty when none is held.
  cv::Mat Find(const std::string& key) const {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const Held& h : held_)
      if (h.key == key) return h.image;
    return cv::Mat();
  }
  cv::Mat Take(const std::string& key) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = held_.begin(); it != held_.end(); ++it) {
      if (it->key != key) continue;
      cv::Mat image = it->image;
      bytes_ -= Bytes(image);
      held_.erase(it);
      return image;
    }
    return cv::Mat();
  }
  size_t size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return held_.size();
  }
  void Clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    held_.clear();
    bytes_ = 0;
  }

 private:
  struct Held {
    std::string key;
    cv::Mat image;
  };
  static size_t Bytes(const cv::Mat& m) { return m.total() * m.elemSize(); }

  const size_t budget_;
  mutable std::mutex mutex_;
  std::deque<Held> held_;
  size_t bytes_ = 0;
};

}  // namespace dome::pipeline
