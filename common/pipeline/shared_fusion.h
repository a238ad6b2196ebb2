// The prepared fusion of an instant (stages.h PrepareFusion: its decoded range images and
// the integrator's tables), built once per key for all of this process's workers. Every
// fusion slab job of an instant needs the same one, and `dome run`'s embedded workers
// each built their own (a quarter of a masked paper fusion job). Built by the first job
// that asks; a job asking meanwhile waits and takes the same one (once_store.h), so the
// builder uses every worker thread of the process (shared_hulls.h ProcessWorkerThreads).
// The latest kSharedPreparedFusions are kept: the instant being fused and the next.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "pipeline/stages.h"

namespace dome::pipeline {

inline constexpr size_t kSharedPreparedFusions = 2;

// The prepared fusion kept under `key`, or the one `build` makes (kept). `key` must name
// all `build` makes it from (the inputs' addresses, the options).
std::shared_ptr<const PreparedFusion> SharedPreparedFusion(
    const std::string& key, const std::function<std::unique_ptr<PreparedFusion>()>& build);

// Builds so far, and dropping every one kept (for tests).
int64_t SharedPreparedFusionBuilds();
void DropSharedPreparedFusions();

}  // namespace dome::pipeline
