#include "pipeline/shared_hulls.h"

#include "pipeline/once_store.h"

namespace dome::pipeline {

std::shared_ptr<const silhouette::VisualHull> SharedHull(
    const std::string& key, const std::function<std::unique_ptr<silhouette::VisualHull>()>& build) {
  static OnceStore<silhouette::VisualHull> store(kSharedHulls);
  return store.Get(key, build);
}

}  // namespace dome::pipeline
