// A worker's cache of blobs by content address (SHA-256 hex), least recently used
// evicted first, bounded in bytes (--cache-mb). Not thread-safe: one owner thread.
#pragma once

#include <cstdint>
#include <list>
#include <memory>
#include <string>
#include <unordered_map>

namespace dome::net {

class BlobCache {
 public:
  explicit BlobCache(int64_t capacity_bytes) : capacity_bytes_(capacity_bytes) {}

  // The blob, or null. Marks it most recently used.
  std::shared_ptr<const std::string> Get(const std::string& sha256);
  // Stores a blob (caller verified the hash); evicts the least recently used until the
  // total fits. A blob larger than the capacity is not kept.
  void Put(const std::string& sha256, std::shared_ptr<const std::string> bytes);

  int64_t bytes() const { return bytes_; }
  size_t size() const { return index_.size(); }
  int64_t hits() const { return hits_; }
  int64_t misses() const { return misses_; }

 private:
  using Entry = std::pair<std::string, std::shared_ptr<const std::string>>;
  int64_t capacity_bytes_;
  int64_t bytes_ = 0;
  int64_t hits_ = 0, misses_ = 0;
  std::list<Entry> lru_;  // front: most recent
  std::unordered_map<std::string, std::list<Entry>::iterator> index_;
};

}  // namespace dome::net
