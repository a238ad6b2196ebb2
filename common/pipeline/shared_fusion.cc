#include "pipeline/shared_fusion.h"

#include "pipeline/once_store.h"

namespace dome::pipeline {
namespace {

OnceStore<PreparedFusion>& Store() {
  // Never destroyed: workers may outlive statics.
  static auto* store = new OnceStore<PreparedFusion>(kSharedPreparedFusions);
  return *store;
}

}  // namespace

std::shared_ptr<const PreparedFusion> SharedPreparedFusion(
    const std::string& key, const std::function<std::unique_ptr<PreparedFusion>()>& build) {
  return Store().Get(key, build);
}

int64_t SharedPreparedFusionBuilds() { return Store().builds(); }

void DropSharedPreparedFusions() { Store().Clear(); }

}  // namespace dome::pipeline
