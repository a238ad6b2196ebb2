// The job graph of a session (SPEC.md "Pipeline"), per instant:
//
//   stereo (one per camera) --> fusion (one per slab of planes; each needs every depth
//   map of the instant) --> surface (the master stitches the slabs in plane order)
//   --> decimate --> texture
//
// Nodes are numbered instant by instant, stage by stage, part by part, and that number
// is the dispatch priority: earlier instants first, and within an instant the earlier
// stage, so instants pipeline (the stereo of instant t+1 runs while instant t fuses).
// Pure bookkeeping: no sockets, no blobs.
#pragma once

#include <array>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

namespace dome::scheduler {

enum class Stage { kStereo = 0, kFusion = 1, kSurface = 2, kDecimate = 3, kTexture = 4, kNoop = 5 };
inline constexpr int kNumStages = 6;
const char* StageName(Stage stage);

enum class JobState { kWaiting, kReady, kRunning, kDone };

struct JobNode {
  std::string key;  // "<instant>/<stage>/<part>", e.g. "00-00-00-01/stereo/c03"
  int instant = 0;  // index into the graph's instants
  Stage stage = Stage::kStereo;
  int part = 0;  // camera index, slab index, 0
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
  JobGraph(const std::vector<std::string>& instants, const std::vector<std::string>& cameras,
           int num_slabs);
  // Benchmarks: `count` independent no-op jobs of one instant "noop".
  static JobGraph Noop(int count);

  int size() const { return int(nodes_.size()); }
  const JobNode& node(int i) const { return nodes_[i]; }
  // The node with this key, or -1.
  int Find(const std::string& key) const;
  const std::vector<std::string>& instants() const { return instants_; }

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
  StageCount Count(int instant, Stage stage) const;

 private:
  JobGraph() = default;
  std::vector<std::string> instants_;
  std::vector<JobNode> nodes_;
  std::unordered_map<std::string, int> index_;  // key -> node
  std::vector<std::array<StageCount, kNumStages>> counts_;
  std::set<int> ready_;
  int done_ = 0;
};

}  // namespace dome::scheduler
