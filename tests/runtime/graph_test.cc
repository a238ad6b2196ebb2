#include "master/graph.h"

#include <gtest/gtest.h>

namespace dome::scheduler {
namespace {

// The default stages' graph: stereo per camera, fusion per slab, then one surface,
// decimate and texture part; stage indices in that order, after the masks stage (no
// parts here: the plan has no mask inputs).
enum Stage { kMasks, kStereo, kFusion, kSurface, kDecimate, kTexture };

JobGraph DefaultShape(const std::vector<std::string>& instants,
                      const std::vector<std::string>& cameras, int slabs) {
  pipeline::SessionPlan plan;
  plan.cameras = cameras;
  plan.num_slabs = slabs;
  return JobGraph(instants, GraphStages(*pipeline::DefaultStages(), plan));
}

TEST(JobGraph, StereoFirstThenSlabsThenSurfaceDecimateTexture) {
  JobGraph g = DefaultShape({"00-00-00-00", "00-00-00-01"}, {"c0", "c1", "c2"}, 4);
  // Per instant: 3 stereo + 4 fusion + surface + decimate + texture.
  ASSERT_EQ(g.size(), 2 * (3 + 4 + 3));
  // Only the stereo jobs are ready at first, instant 0 before instant 1.
  std::vector<std::string> ready;
  for (int i : g.ready()) ready.push_back(g.node(i).key);
  EXPECT_EQ(ready, (std::vector<std::string>{"00-00-00-00/stereo/c0", "00-00-00-00/stereo/c1",
                                             "00-00-00-00/stereo/c2", "00-00-00-01/stereo/c0",
                                             "00-00-00-01/stereo/c1", "00-00-00-01/stereo/c2"}));
  // Fusion needs every depth map of its instant.
  const int s0 = g.Find("00-00-00-00/stereo/c0");
  const int s1 = g.Find("00-00-00-00/stereo/c1");
  const int s2 = g.Find("00-00-00-00/stereo/c2");
  g.MarkRunning(s0);
  EXPECT_TRUE(g.MarkDone(s0).empty());
  EXPECT_TRUE(g.MarkDone(s1).empty());
  const std::vector<int> fusion = g.MarkDone(s2);
  ASSERT_EQ(fusion.size(), 4u);
  for (int k = 0; k < 4; ++k)
    EXPECT_EQ(g.node(fusion[k]).key, "00-00-00-00/fusion/" + std::to_string(k));
  // Instant 0's fusion outranks instant 1's stereo (earlier instants first).
  EXPECT_EQ(*g.ready().begin(), fusion[0]);
  EXPECT_EQ(g.Count(0, kStereo).done, 3);
  EXPECT_EQ(g.Count(0, kFusion).total, 4);
  // The surface waits for every slab.
  for (int k = 0; k < 3; ++k) EXPECT_TRUE(g.MarkDone(fusion[k]).empty());
  const std::vector<int> surface = g.MarkDone(fusion[3]);
  ASSERT_EQ(surface.size(), 1u);
  EXPECT_EQ(g.node(surface[0]).key, "00-00-00-00/surface");
  const std::vector<int> decimate = g.MarkDone(surface[0]);
  ASSERT_EQ(decimate.size(), 1u);
  EXPECT_EQ(g.node(decimate[0]).stage, kDecimate);
  const std::vector<int> texture = g.MarkDone(decimate[0]);
  ASSERT_EQ(texture.size(), 1u);
  EXPECT_FALSE(g.InstantDone(0));
  EXPECT_TRUE(g.MarkDone(texture[0]).empty());
  EXPECT_TRUE(g.InstantDone(0));
  EXPECT_FALSE(g.AllDone());
  EXPECT_EQ(g.done(), 10);
}

TEST(JobGraph, RequeueAndDuplicateDone) {
  JobGraph g = DefaultShape({"t0"}, {"a", "b"}, 1);
  const int a = g.Find("t0/stereo/a");
  g.MarkRunning(a);
  EXPECT_EQ(g.ready().count(a), 0u);
  g.Requeue(a);  // its worker was lost
  EXPECT_EQ(g.ready().count(a), 1u);
  g.MarkRunning(a);
  g.MarkDone(a);
  // A second (late, duplicate) result changes nothing.
  EXPECT_TRUE(g.MarkDone(a).empty());
  EXPECT_EQ(g.done(), 1);
  EXPECT_EQ(g.Count(0, kStereo).done, 1);
  EXPECT_EQ(g.Find("t0/stereo/zz"), -1);
}

TEST(JobGraph, DoneOutOfOrderFromAJournal) {
  // A resumed session marks jobs done in the journal's order; the later stages must
  // not become ready before all their inputs are done.
  JobGraph g = DefaultShape({"t0"}, {"a", "b"}, 2);
  g.MarkDone(g.Find("t0/fusion/0"));
  g.MarkDone(g.Find("t0/stereo/a"));
  std::vector<std::string> ready;
  for (int i : g.ready()) ready.push_back(g.node(i).key);
  EXPECT_EQ(ready, (std::vector<std::string>{"t0/stereo/b"}));
  const std::vector<int> now = g.MarkDone(g.Find("t0/stereo/b"));
  ASSERT_EQ(now.size(), 1u);
  EXPECT_EQ(g.node(now[0]).key, "t0/fusion/1");
}

// A stage with no parts in a session (the no-op stage of a reconstruction) is not in
// the graph, and the stages after it do not wait for it.
TEST(JobGraph, StagesWithoutPartsAreSkipped) {
  JobGraph g({"t0"}, {{"a", {"0", "1"}, {}}, {"empty", {}, {}}, {"b", {""}, {0, 1}}});
  EXPECT_EQ(g.size(), 3);
  EXPECT_EQ(g.Count(0, 1).total, 0);
  EXPECT_EQ(g.NodeOf(0, 2, 0), g.Find("t0/b"));
  g.MarkDone(g.Find("t0/a/0"));
  const std::vector<int> now = g.MarkDone(g.Find("t0/a/1"));
  ASSERT_EQ(now.size(), 1u);
  EXPECT_EQ(g.node(now[0]).key, "t0/b");
}

// With temporal stereo a camera's stereo at instant t waits for its own at t-1, and for
// nothing else of t-1: the other cameras, and t-1's fusion and later stages, stay apart.
TEST(JobGraph, TemporalStereoWaitsForItsCameraAtThePreviousInstant) {
  pipeline::SessionPlan plan;
  plan.cameras = {"c0", "c1"};
  plan.num_slabs = 1;
  plan.options.temporal.stereo = true;
  JobGraph g({"t0", "t1", "t2"}, GraphStages(*pipeline::DefaultStages(), plan));
  std::vector<std::string> ready;
  for (int i : g.ready()) ready.push_back(g.node(i).key);
  EXPECT_EQ(ready, (std::vector<std::string>{"t0/stereo/c0", "t0/stereo/c1"}));
  const std::vector<int> now = g.MarkDone(g.Find("t0/stereo/c1"));
  ASSERT_EQ(now.size(), 1u);
  EXPECT_EQ(g.node(now[0]).key, "t1/stereo/c1");
  // t1's c1 done before t0's c0: t2's c1 runs, t1's c0 still waits.
  const std::vector<int> next = g.MarkDone(now[0]);
  ASSERT_EQ(next.size(), 1u);
  EXPECT_EQ(g.node(next[0]).key, "t2/stereo/c1");
  EXPECT_EQ(g.node(g.Find("t1/stereo/c0")).state, JobState::kWaiting);
  // t0's c0 frees t1's c0 and t0's fusion together.
  std::vector<std::string> freed;
  for (int i : g.MarkDone(g.Find("t0/stereo/c0"))) freed.push_back(g.node(i).key);
  EXPECT_EQ(freed, (std::vector<std::string>{"t0/fusion/0", "t1/stereo/c0"}));
  // Off (the default), every instant's stereo is ready at once.
  plan.options.temporal.stereo = false;
  EXPECT_EQ(JobGraph({"t0", "t1", "t2"}, GraphStages(*pipeline::DefaultStages(), plan))
                .ready()
                .size(),
            6u);
}

// With temporal fusion a slab at instant t waits for its own slab at t-1 (whose evidence
// it adds) as well as for t's stereo; t-1's other slabs and t's stereo stay apart.
TEST(JobGraph, TemporalFusionWaitsForItsSlabAtThePreviousInstant) {
  pipeline::SessionPlan plan;
  plan.cameras = {"c0"};
  plan.num_slabs = 2;
  plan.options.temporal.fusion = true;
  JobGraph g({"t0", "t1"}, GraphStages(*pipeline::DefaultStages(), plan));
  std::vector<std::string> ready;
  for (int i : g.ready()) ready.push_back(g.node(i).key);
  EXPECT_EQ(ready, (std::vector<std::string>{"t0/stereo/c0", "t1/stereo/c0"}));
  std::vector<std::string> freed;
  for (int i : g.MarkDone(g.Find("t0/stereo/c0"))) freed.push_back(g.node(i).key);
  EXPECT_EQ(freed, (std::vector<std::string>{"t0/fusion/0", "t0/fusion/1"}));
  EXPECT_TRUE(g.MarkDone(g.Find("t1/stereo/c0")).empty());  // each waits for its slab
  freed.clear();
  for (int i : g.MarkDone(g.Find("t0/fusion/1"))) freed.push_back(g.node(i).key);
  EXPECT_EQ(freed, (std::vector<std::string>{"t1/fusion/1"}));
  EXPECT_EQ(g.node(g.Find("t1/fusion/0")).state, JobState::kWaiting);
}

}  // namespace
}  // namespace dome::scheduler
