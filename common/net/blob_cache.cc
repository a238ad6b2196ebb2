#include "net/blob_cache.h"

namespace dome::net {

std::shared_ptr<const std::string> BlobCache::Get(const std::string& sha256) {
  auto it = index_.find(sha256);
  if (it == index_.end()) {
    ++misses_;
    return nullptr;
  }
  ++hits_;
  lru_.splice(lru_.begin(), lru_, it->second);
  return it->second->second;
}

void BlobCache::Put(const std::string& sha256, std::shared_ptr<const std::string> bytes) {
  if (index_.count(sha256) != 0) return;
  const int64_t n = int64_t(bytes->size());
  if (n > capacity_bytes_) return;
  while (bytes_ + n > capacity_bytes_ && !lru_.empty()) {
    bytes_ -= int64_t(lru_.back().second->size());
    index_.erase(lru_.back().first);
    lru_.pop_back();
  }
  lru_.emplace_front(sha256, std::move(bytes));
  index_[sha256] = lru_.begin();
  bytes_ += n;
}

}  // namespace dome::net
