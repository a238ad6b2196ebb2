// A stage added by a descriptor alone (pipeline/stage.h): the scheduler runs it with
// no change of its own. Here a "count" stage after texture, run on the workers of an
// embedded cluster: it counts the decimated mesh's triangles and writes
// OUT/<instant>/count.txt.
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "cli/client.h"
#include "core/error.h"
#include "io/file_util.h"
#include "io/ply.h"
#include "pipeline/session.h"
#include "pipeline/stage.h"
#include "pipeline/stages.h"
#include "testing/run_command.h"
#include "testing/temp_dir.h"

namespace dome {
namespace {

namespace fs = std::filesystem;

pipeline::StageDescriptor CountStage() {
  pipeline::StageDescriptor d;
  d.name = "count";
  d.after = {"texture"};
  d.parts = [](const pipeline::SessionPlan& plan) {
    return plan.spec.noop_jobs() > 0 ? std::vector<std::string>{} : std::vector<std::string>{""};
  };
  d.make_job = [](const pipeline::JobContext& ctx, runtime::Job* job) {
    *job->add_blobs() = ctx.outputs("texture", 0).at(0);  // mesh_decimated.ply
  };
  d.run = [](const runtime::Job& job, const pipeline::JobBlobs& blobs, pipeline::JobMemo*) {
    runtime::Output out;
    out.set_name("count.txt");
    out.set_data(std::to_string(io::ParsePly(*blobs.at(0), job.id()).faces.size()) + "\n");
    return std::vector<runtime::Output>{out};
  };
  d.store = [](const pipeline::StoreContext& ctx, const runtime::JobResult& r) {
    const std::string& bytes = pipeline::OutputBytes(r, "count.txt", ctx.where);
    io::WriteFileAtomically(ctx.dir / "count.txt", bytes);
    return pipeline::StoredResult{{ctx.blobs->Keep(bytes, "count.txt")}, nullptr};
  };
  return d;
}

TEST(StageSet, AStageAddedByADescriptorRunsWithTheOthers) {
  const testing::TempDir dir;
  const fs::path take = dir / "take", out = dir / "out";
  ASSERT_EQ(testing::RunDomeBinary("synth --preset small --instants 2 --no-tape --no-calib "
                                   "--threads 2 --out " +
                                   take.string())
                .exit_code,
            0);
  auto stages = std::make_shared<pipeline::StageSet>(*pipeline::DefaultStages());
  stages->stages.push_back(CountStage());
  client::EmbeddedOptions options;
  options.workers = 2;
  options.threads_per_worker = 1;
  options.master.stages = stages;
  runtime::Session session;
  session.set_take(take.string());
  session.set_out(out.string());
  session.mutable_volume()->set_voxel_size_mm(40);
  session.set_slab_planes(10);
  session.set_texture(false);
  const runtime::SessionStatus status = client::RunEmbedded(session, options, nullptr);
  ASSERT_EQ(status.state(), "done") << status.error();
  ASSERT_EQ(status.instants_size(), 2);
  for (const auto& instant : status.instants()) {
    // The count is the decimated mesh's, and the status shows the stage.
    const io::Mesh decimated = io::ReadPly(out / instant.instant() / "mesh_decimated.ply");
    EXPECT_EQ(io::ReadFileBytes(out / instant.instant() / "count.txt"),
              std::to_string(decimated.faces.size()) + "\n");
    ASSERT_EQ(instant.stages_size(), 6);
    EXPECT_EQ(instant.stages(5).stage(), "count");
    EXPECT_EQ(instant.stages(5).done(), 1);
  }
  const auto report = nlohmann::json::parse(io::ReadFileBytes(out / "report.json"));
  EXPECT_EQ(report["stages"]["count"]["jobs"], 2) << report;
  // The journal records it like any other job.
  const std::string journal = io::ReadFileBytes(out / "journal.log");
  // "done <instant>/count @<inputs digest> count.txt=<sha256>"
  EXPECT_NE(journal.find("/count @"), std::string::npos) << journal;
  EXPECT_NE(journal.find(" count.txt="), std::string::npos) << journal;
}

// A worker that does not know a job's stage fails it, naming the stage: the master and
// its workers must run the same stage set.
TEST(StageSet, AWorkerWithoutTheStageFailsTheSessionNamingIt) {
  const testing::TempDir dir;
  const fs::path take = dir / "take";
  ASSERT_EQ(testing::RunDomeBinary("synth --preset small --instants 1 --no-tape --no-calib "
                                   "--threads 2 --out " +
                                   take.string())
                .exit_code,
            0);
  auto stages = std::make_shared<pipeline::StageSet>();
  pipeline::StageDescriptor d = CountStage();
  d.after.clear();
  d.make_job = [](const pipeline::JobContext&, runtime::Job*) {};
  stages->stages.push_back(d);
  client::EmbeddedOptions options;
  options.workers = 1;
  options.master.stages = stages;  // the workers get it too: make them run the default set
  options.worker_stages = pipeline::DefaultStages();
  runtime::Session session;
  session.set_take(take.string());
  session.set_out((dir / "out").string());
  const runtime::SessionStatus status = client::RunEmbedded(session, options, nullptr);
  EXPECT_EQ(status.state(), "failed");
  EXPECT_NE(status.error().find("names no stage a worker runs ('count')"), std::string::npos)
      << status.error();
}

// `dome run`'s in-process workers when none are asked for: two, each with every thread
// for a session of one instant, with half of them for more (instants counted from the
// take when the session names none); a take that cannot be opened is named.
TEST(EmbeddedWorkers, TwoWithEveryThreadForOneInstantWithHalfForMore) {
  runtime::Session s;
  s.add_instants("00-00-00-00");
  EXPECT_EQ(client::DefaultEmbeddedWorkers(s, 2).workers, 2);
  EXPECT_EQ(client::DefaultEmbeddedWorkers(s, 2).threads_per_worker, 2);
  EXPECT_EQ(client::DefaultEmbeddedWorkers(s, 8).threads_per_worker, 8);
  s.add_instants("00-00-00-05");
  EXPECT_EQ(client::DefaultEmbeddedWorkers(s, 2).workers, 2);
  EXPECT_EQ(client::DefaultEmbeddedWorkers(s, 2).threads_per_worker, 1);
  EXPECT_EQ(client::DefaultEmbeddedWorkers(s, 8).threads_per_worker, 4);
  EXPECT_EQ(client::DefaultEmbeddedWorkers(s, 1).threads_per_worker, 1);
  runtime::Session noop;
  noop.set_noop_jobs(10);
  EXPECT_EQ(client::DefaultEmbeddedWorkers(noop, 2).workers, 2);
  EXPECT_EQ(client::DefaultEmbeddedWorkers(noop, 2).threads_per_worker, 1);
  testing::TempDir dir;
  runtime::Session missing;
  missing.set_take((dir / "no-take").string());
  EXPECT_THROW(client::DefaultEmbeddedWorkers(missing, 2), core::InputError);
}

}  // namespace
}  // namespace dome
