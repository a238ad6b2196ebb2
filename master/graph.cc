#include "master/graph.h"

#include "core/error.h"

namespace dome::scheduler {

std::vector<GraphStage> GraphStages(const pipeline::StageSet& stages,
                                    const pipeline::SessionPlan& plan) {
  std::vector<GraphStage> out;
  for (const pipeline::StageDescriptor& d : stages.stages) {
    GraphStage g{d.name, d.parts(plan), {}};
    for (const std::string& a : d.after) g.after.push_back(stages.Find(a));
    g.after_previous_instant = d.after_previous_instant && d.after_previous_instant(plan);
    out.push_back(std::move(g));
  }
  return out;
}

JobGraph::JobGraph(const std::vector<std::string>& instants, const std::vector<GraphStage>& stages)
    : instants_(instants),
      stages_(stages),
      first_(instants.size(), std::vector<int>(stages.size(), 0)),
      counts_(instants.size(), std::vector<StageCount>(stages.size())) {
  for (int t = 0; t < int(instants.size()); ++t) {
    for (int s = 0; s < int(stages.size()); ++s) {
      const GraphStage& stage = stages[s];
      first_[t][s] = int(nodes_.size());
      for (int p = 0; p < int(stage.parts.size()); ++p) {
        JobNode n;
        n.key =
            instants[t] + "/" + stage.name + (stage.parts[p].empty() ? "" : "/" + stage.parts[p]);
        n.instant = t;
        n.stage = s;
        n.part = p;
        for (int a : stage.after) {
          DOME_CHECK(a >= 0 && a < s, "a stage comes after earlier stages only");
          for (int q = 0; q < int(stages[a].parts.size()); ++q) {
            nodes_[first_[t][a] + q].dependents.push_back(int(nodes_.size()));
            ++n.pending;
          }
        }
        if (stage.after_previous_instant && t > 0) {
          nodes_[first_[t - 1][s] + p].dependents.push_back(int(nodes_.size()));
          ++n.pending;
        }
        index_[n.key] = int(nodes_.size());
        nodes_.push_back(std::move(n));
        ++counts_[t][s].total;
      }
    }
  }
  for (int i = 0; i < int(nodes_.size()); ++i) {
    if (nodes_[i].pending == 0) {
      nodes_[i].state = JobState::kReady;
      ready_.insert(i);
    }
  }
}

int JobGraph::Find(const std::string& key) const {
  auto it = index_.find(key);
  return it == index_.end() ? -1 : it->second;
}

int JobGraph::NodeOf(int instant, int stage, int part) const {
  DOME_CHECK(part >= 0 && part < int(stages_[stage].parts.size()), "a part of the stage");
  return first_[instant][stage] + part;
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
  ++counts_[n.instant][n.stage].done;
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

StageCount JobGraph::Count(int instant, int stage) const { return counts_[instant][stage]; }

}  // namespace dome::scheduler
