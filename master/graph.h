// The job graph of a session (SPEC.md "Pipeline"), built from its stages
// (pipeline/stage.h): per instant, each stage's parts, each part waiting for every part
// of the stages it comes after in that instant and, for a stage that says so, its own
// part of the previous instant. For the default stages:
//
//   stereo (one per camera) --> fusion (one per slab of planes; each needs every depth
//   map of the instant) --> surface (the master stitches the slabs in plane order)
//   --> decimate --> texture
//
// and with temporal stereo, stereo of camera c at instant t after stereo of c at t-1.
//
// Nodes are numbered instant by instant, stage by stage, part by part, and that number
// is the dispatch priority: earlier instants first, and within an instant the earlier
// stage, so instants pipeline (the stereo of instant t+1 runs while instant t fuses).
// Pure bookkeeping: no sockets, no blobs, no stage known by name.
#pragma once

#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include "pipeline/stage.h"

namespace dome::scheduler {

// One stage of the graph: its name, its parts in each instant ("" for a one-part stage)
// and the stages (indices into the graph's stages, earlier ones) it comes after.
struct GraphStage {
  std::string name;
  std::vector<std::string> parts;
  std::vector<int> after;
  bool after_previous_instant = false;  // part p at t waits for part p at t-1
};

// The graph stages of `stages` for `plan`: each descriptor's parts and its `after`.
std::vector<GraphStage> GraphStages(const pipeline::StageSet& stages,
                                    const pipeline::SessionPlan& plan);

enum class JobState { kWaiting, kReady, kRunning, kDone };

struct JobNode {
  std::string key;  // "<instant>/<stage>[/<part>]", e.g. "00-00-00-01/stereo/c03"
  int instant = 0;  // index into the graph's instants
  int stage = 0;    // index into the graph's stages
  int part = 0;     // index into the stage's parts
  JobState state = JobState::kWaiting;
  int pending = 0;              // dependencies not done yet
  std::vector<int> dependents;  // nodes waiting on this one
};

struct StageCount {
  int done = 0;
  int total = 0;
};

class JobGraph {
 public:
  JobGraph(const std::vector<std::string>& instants, const std::vector<GraphStage>& stages);

  int size() const { return int(nodes_.size()); }
  const JobNode& node(int i) const { return nodes_[i]; }
  // The node with this key, or -1.
  int Find(const std::string& key) const;
  // The node of part `part` of stage `stage` in instant `instant`.
  int NodeOf(int instant, int stage, int part) const;
  const std::vector<std::string>& instants() const { return instants_; }
  const std::vector<GraphStage>& stages() const { return stages_; }

  // Ready nodes in priority order.
  const std::set<int>& ready() const { return ready_; }
  // kReady -> kRunning.
  void MarkRunning(int i);
  // kRunning -> kReady (its worker was lost).
  void Requeue(int i);
  // Any state but kDone -> kDone; dependents whose last dependency this was become
  // ready. Returns them. Marking a done node again returns nothing.
  std::vector<int> MarkDone(int i);

  bool AllDone() const { return done_ == int(nodes_.size()); }
  int done() const { return done_; }
  bool InstantDone(int instant) const;
  StageCount Count(int instant, int stage) const;

 private:
  std::vector<std::string> instants_;
  std::vector<GraphStage> stages_;
  std::vector<JobNode> nodes_;
  std::unordered_map<std::string, int> index_;   // key -> node
  std::vector<std::vector<int>> first_;          // [instant][stage] -> its first node
  std::vector<std::vector<StageCount>> counts_;  // [instant][stage]
  std::set<int> ready_;
  int done_ = 0;
};

}  // namespace dome::scheduler
