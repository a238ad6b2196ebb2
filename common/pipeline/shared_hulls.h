// The visual hulls of this process's jobs, built once per key for all its workers
// (`dome run --workers N` runs N in one process): every stereo job of an instant needs
// the hull of the instant's masks, every fusion job the same hull with its distances,
// and each worker built its own copy. A hull is built by the first job that asks; a
// job asking while it is built waits for it and takes the same one (once_store.h). The
// latest kSharedHulls are kept: the stereo and fusion hulls of about two instants.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "silhouette/hull.h"

namespace dome::pipeline {

inline constexpr size_t kSharedHulls = 4;

// The job threads of the workers running in this process, each counted while a
// WorkerThreads object of its lifetime exists (0 when none). A shared hull is asked for
// by every worker of the process at about the same time (the stereo jobs of an instant,
// then its fusion jobs), and those that find it being built wait: its builder takes all
// their threads (jobs.cc HullBlobs). In `dome run --workers 2` of one thread each, the
// second worker's wait becomes the first's second thread. A lone worker process counts
// only its own threads, so a worker limited to fewer threads than the machine's stays so.
int ProcessWorkerThreads();
class WorkerThreads {
 public:
  explicit WorkerThreads(int threads);
  ~WorkerThreads();
  WorkerThreads(const WorkerThreads&) = delete;
  WorkerThreads& operator=(const WorkerThreads&) = delete;

  // Whether this worker has no job running or queued (the master has nothing for it
  // yet, since it sends jobs ahead): its threads then count in IdleWorkerThreads. A new
  // object is not idle.
  void SetIdle(bool idle);

 private:
  int threads_;
  bool idle_ = false;
};

// The threads of this process's workers that are idle (above).
int IdleWorkerThreads();

// The threads a job that borrows (StageDescriptor::borrows_idle_threads) runs on when it
// starts now on a worker of `own` threads: `own` plus the idle workers' threads, at most
// the machine's (or `own` when more). At the end of a take the last instants'
// decimations run one to a worker, and a worker of one thread in `dome run --workers 2`
// left the other core idle for most of Panoptic's last 14 s. Every job's result is the
// same on any number of threads, and a lender that gets a job meanwhile runs it beside
// (the cores are shared for the rest of the borrower's job).
int LentThreads(int own);

// The hull kept under `key`, or the one `build` makes (kept). `key` must name all
// `build` makes the hull from (the masks' addresses, the rule, the options).
std::shared_ptr<const silhouette::VisualHull> SharedHull(
    const std::string& key, const std::function<std::unique_ptr<silhouette::VisualHull>()>& build);

}  // namespace dome::pipeline
