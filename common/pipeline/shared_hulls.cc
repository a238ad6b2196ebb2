#include "pipeline/shared_hulls.h"

#include <algorithm>
#include <atomic>

#include "core/parallel_for.h"
#include "pipeline/once_store.h"

namespace dome::pipeline {
namespace {

std::atomic<int>& Held() {
  static std::atomic<int> threads{0};
  return threads;
}

std::atomic<int>& Idle() {
  static std::atomic<int> threads{0};
  return threads;
}

}  // namespace

int ProcessWorkerThreads() { return Held().load(); }

WorkerThreads::WorkerThreads(int threads) : threads_(std::max(0, threads)) {
  Held() += threads_;
}

WorkerThreads::~WorkerThreads() {
  SetIdle(false);
  Held() -= threads_;
}

void WorkerThreads::SetIdle(bool idle) {
  if (idle == idle_) return;
  idle_ = idle;
  Idle() += idle ? threads_ : -threads_;
}

int IdleWorkerThreads() { return Idle().load(); }

int LentThreads(int own) {
  return std::max(own, std::min(own + IdleWorkerThreads(), core::HardwareThreads()));
}

std::shared_ptr<const silhouette::VisualHull> SharedHull(
    const std::string& key, const std::function<std::unique_ptr<silhouette::VisualHull>()>& build) {
  static OnceStore<silhouette::VisualHull> store(kSharedHulls);
  return store.Get(key, build);
}

}  // namespace dome::pipeline
