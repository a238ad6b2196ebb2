#include "pipeline/shared_hulls.h"

#include <algorithm>
#include <atomic>

#include "pipeline/once_store.h"

namespace dome::pipeline {
namespace {

std::atomic<int>& Held() {
  static std::atomic<int> threads{0};
  return threads;
}

}  // namespace

int ProcessWorkerThreads() { return Held().load(); }

WorkerThreads::WorkerThreads(int threads) : threads_(std::max(0, threads)) {
  Held() += threads_;
}

WorkerThreads::~WorkerThreads() { Held() -= threads_; }

std::shared_ptr<const silhouette::VisualHull> SharedHull(
    const std::string& key, const std::function<std::unique_ptr<silhouette::VisualHull>()>& build) {
  static OnceStore<silhouette::VisualHull> store(kSharedHulls);
  return store.Get(key, build);
}

}  // namespace dome::pipeline
