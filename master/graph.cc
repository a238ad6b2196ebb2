#include "master/graph.h"

#include "core/error.h"

namespace dome::scheduler {

const char* StageName(Stage stage) {
  switch (stage) {
    case Stage::kStereo:
      return "stereo";
    case Stage::kFusion:
      return "fusion";
    case Stage::kSurface:
      return "surface";
    case Stage::kDecimate:
      return "decimate";
    case Stage::kTexture:
      return "texture";
    case Stage::kNoop:
      return "noop";
  }
  return "?";
}

JobGraph::JobGraph(const std::vector<std::string>& instants,
                   const std::vector<std::string>& cameras, int num_slabs)
    : instants_(instants), counts_(instants.size()) {
  DOME_CHECK(!cameras.empty() && num_slabs > 0, "a graph needs cameras and slabs");
  for (int t = 0; t < int(instants.size()); ++t) {
    const std::string& in = instants[t];
    auto add = [&](Stage stage, int part, const std::string& name) {
      JobNode n;
      n.key = in + "/" + StageName(stage) + (name.empty() ? "" : "/" + name);
      n.instant = t;
      n.stage = stage;
      n.part = part;
      index_[n.key] = int(nodes_.size());
      nodes_.push_back(n);
      ++counts_[t][int(stage)].total;
      return int(nodes_.size()) - 1;
    };
    auto depend = [&](int node, int on) {
      nodes_[on].dependents.push_back(node);
      ++nodes_[node].pending;
    };
    std::vector<int> stereo, fusion;
    for (int c = 0; c < int(cameras.size()); ++c)
      stereo.push_back(add(Stage::kStereo, c, cameras[c]));
    for (int s = 0; s < num_slabs; ++s) {
      const int f = add(Stage::kFusion, s, std::to_string(s));
      for (int d : stereo) depend(f, d);
      fusion.push_back(f);
    }
    const int surface = add(Stage::kSurface, 0, "");
    for (int f : fusion) depend(surface, f);
    const int decimate = add(Stage::kDecimate, 0, "");
    depend(decimate, surface);
    const int texture = add(Stage::kTexture, 0, "");
    depend(texture, decimate);
  }
  for (int i = 0; i < int(nodes_.size()); ++i) {
    if (nodes_[i].pending == 0) {
      nodes_[i].state = JobState::kReady;
      ready_.insert(i);
    }
  }
}

JobGraph JobGraph::Noop(int count) {
  JobGraph g;
  g.instants_ = {"noop"};
  g.counts_.resize(1);
  for (int i = 0; i < count; ++i) {
    JobNode n;
    n.key = "noop/noop/" + std::to_string(i);
    n.stage = Stage::kNoop;
    n.part = i;
    n.state = JobState::kReady;
    g.index_[n.key] = i;
    g.nodes_.push_back(n);
    g.ready_.insert(i);
  }
  g.counts_[0][int(Stage::kNoop)].total = count;
  return g;
}

int JobGraph::Find(const std::string& key) const {
  auto it = index_.find(key);
  return it == index_.end() ? -1 : it->second;
}

void JobGraph::MarkRunning(int i) {
  DOME_CHECK(nodes_[i].state == JobState::kReady, "only a ready job can run");
  nodes_[i].state = JobState::kRunning;
  ready_.erase(i);
}

void JobGraph::Requeue(int i) {
  DOME_CHECK(nodes_[i].state == JobState::kRunning, "only a running job is re-queued");
  nodes_[i].state = JobState::kReady;
  ready_.insert(i);
}

std::vector<int> JobGraph::MarkDone(int i) {
  JobNode& n = nodes_[i];
  if (n.state == JobState::kDone) return {};
  ready_.erase(i);
  n.state = JobState::kDone;
  ++done_;
  ++counts_[n.instant][int(n.stage)].done;
  std::vector<int> now_ready;
  for (int d : n.dependents) {
    JobNode& m = nodes_[d];
    if (--m.pending == 0 && m.state == JobState::kWaiting) {
      m.state = JobState::kReady;
      ready_.insert(d);
      now_ready.push_back(d);
    }
  }
  return now_ready;
}

bool JobGraph::InstantDone(int instant) const {
  for (const StageCount& c : counts_[instant]) {
    if (c.done != c.total) return false;
  }
  return true;
}

StageCount JobGraph::Count(int instant, Stage stage) const { return counts_[instant][int(stage)]; }

}  // namespace dome::scheduler
