// Faults of the distributed runtime with real processes on loopback (issue 8's
// acceptance): a worker frozen past the heartbeat timeout and resumed, the master
// killed and restarted on the same output folder, a worker joining mid-session. Each
// run must end with the same bytes as the undisturbed embedded `dome run` and a log
// line saying what was retried. (Workers killed during stereo and fusion:
// cluster_test.cc.)
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>

#include "io/file_util.h"
#include "runtime/cluster_fixture.h"
#include "runtime/process.h"

namespace dome {
namespace {
namespace fs = std::filesystem;
using testing::ChildProcess;
using testing::CountOf;
using testing::ExpectSameOutputs;

class Faults : public testing::ClusterFixture {
 protected:
  // The integer after "\"key\": " in report.json text; -1 when absent.
  static int ReportInt(const std::string& report, const std::string& key) {
    const std::string needle = "\"" + key + "\": ";
    const auto p = report.find(needle);
    if (p == std::string::npos) return -1;
    return std::stoi(report.substr(p + needle.size()));
  }
  // Waits until `pred()` holds, checking every 10 ms; false after timeout_s.
  template <typename Pred>
  static bool Eventually(Pred pred, double timeout_s = 30) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < end) {
      if (pred()) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }
  // The stage totals of one instant of a status.
  static int Total(const runtime::SessionStatus& st, int instant, const std::string& stage) {
    for (const auto& s : st.instants(instant).stages()) {
      if (s.stage() == stage) return s.total();
    }
    return -1;
  }
};

TEST_F(Faults, FrozenWorkerIsRequeuedAndItsLateResultDropped) {
  Master m = StartMaster("master_freeze");
  auto frozen = StartWorker(m, "f1");
  const fs::path out = root_ / "frozen";
  const std::string id = Submit(m, MakeSession(out));
  // One worker: once a depth map is in, it is busy with the next stereo job. Freeze it
  // well inside that job (a stereo job takes a good part of a second here).
  ASSERT_TRUE(WaitFor(m, id, [](const auto& st) { return Done(st, 0, "stereo") >= 1; }));
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  frozen->Signal(SIGSTOP);
  // Past 3 x 200 ms without a heartbeat the master re-queues its job; a second worker
  // runs it.
  const std::string requeued = "lost (no heartbeat for 600 ms); re-queued job " + id + "/";
  ASSERT_TRUE(Eventually([&] { return m.process->Log().find(requeued) != std::string::npos; }))
      << m.process->Log();
  auto helper = StartWorker(m, "f2");
  const std::string log = m.process->Log();
  const auto at = log.find(requeued) + requeued.size() - id.size() - 1;
  const std::string job =
      log.substr(at, log.find(' ', at) - at);  // "<id>/<instant>/<stage>/<part>"
  const std::string key = job.substr(id.size() + 1);
  const std::string instant = key.substr(0, key.find('/'));
  const std::string stage = key.substr(instant.size() + 1, key.rfind('/') - instant.size() - 1);
  const int t = instant == instants_[0] ? 0 : 1;
  ASSERT_TRUE(WaitFor(m, id, [&](const auto& st) {
    return Done(st, t, stage) == Total(st, t, stage);
  })) << job;
  // Resumed, the frozen worker finishes its job: the master has it already.
  frozen->Signal(SIGCONT);
  const auto final = WaitForEnd(m, id);
  ASSERT_EQ(final.state(), "done") << final.error() << m.process->Log();
  ExpectSameOutputs(reference_, out);
  // The frozen worker may have held more than one job (a job running, the next one
  // assigned): the late result dropped is one of them. It is a duplicate while the
  // session runs, or a result of a session already done when the other worker
  // finished everything first.
  const std::string duplicate = "late or duplicate result for " + id + "/";
  const std::string after_end = "of done session " + id + " dropped";
  ASSERT_TRUE(Eventually([&] {
    const std::string log = m.process->Log();
    return log.find(duplicate) != std::string::npos || log.find(after_end) != std::string::npos;
  })) << m.process->Log();
  const std::string report = io::ReadFileBytes(out / "report.json");
  EXPECT_GE(ReportInt(report, "jobs_requeued"), 1) << report;
  if (m.process->Log().find(duplicate) != std::string::npos) {
    EXPECT_GE(ReportInt(report, "duplicate_results_dropped"), 1) << report;
  }
}

TEST_F(Faults, KilledMasterRestartsFromItsJournal) {
  Master m1 = StartMaster("master_before");
  // One worker before the kill: earlier instants first, so when the first instant is
  // done most of the second is still to do (two workers may finish it by then).
  auto w1 = StartWorker(m1, "r1");
  const fs::path out = root_ / "restarted";
  const runtime::Session session = MakeSession(out);
  const std::string id1 = Submit(m1, session);
  // Mid-session: the first instant done, the second under way.
  ASSERT_TRUE(WaitFor(m1, id1, [](const auto& st) { return st.instants(0).done(); }));
  m1.process->Kill();
  // A new master on the same worker port; the workers find it by themselves.
  auto w2 = StartWorker(m1, "r2");
  Master m2 = StartMaster("master_after", {}, m1.workers);
  ASSERT_EQ(m2.workers, m1.workers);
  const std::string id2 = Submit(m2, session);
  const auto resumed = Status(m2, id2);
  const int total = resumed.jobs_total();
  EXPECT_GE(resumed.jobs_done(), total / 2) << "the first instant's jobs are in the journal";
  const auto final = WaitForEnd(m2, id2);
  ASSERT_EQ(final.state(), "done") << final.error() << m2.process->Log();
  ExpectSameOutputs(reference_, out);
  const std::string log = m2.process->Log();
  EXPECT_NE(log.find("session " + id2 + ": resumed from " + (out / "journal.log").string() + ": " +
                     std::to_string(resumed.jobs_done()) + " jobs already done"),
            std::string::npos)
      << log;
  // The restarted master ran only what the journal lacked.
  const std::string report = io::ReadFileBytes(out / "report.json");
  EXPECT_EQ(ReportInt(report, "jobs_resumed_from_journal"), resumed.jobs_done()) << report;
  const int after = std::max(0, ReportInt(report, "r1")) + std::max(0, ReportInt(report, "r2"));
  EXPECT_GT(after, 0) << report;
  EXPECT_LT(after, total) << report;
  EXPECT_LE(after, total - resumed.jobs_done()) << report;
  // Both workers find the new master by themselves; the rest of the session may end
  // before the second one has, so it is waited for, not expected already.
  EXPECT_TRUE(Eventually([&] {
    const std::string now = m2.process->Log();
    return now.find("worker r1 joined") != std::string::npos &&
           now.find("worker r2 joined") != std::string::npos;
  }))
      << m2.process->Log();
}

TEST_F(Faults, WorkerJoiningMidSessionGetsJobs) {
  // The first worker is held (SIGSTOP) from its third result until the second worker has
  // finished a job: left running, on a loaded machine it can end the session before the
  // second has started. A long liveness on both sides and a long job time-out keep the
  // held worker from being lost or its job re-queued.
  Master m = StartMaster("master_join", {"--liveness", "150", "--job-timeout-s", "600"});
  auto first = StartWorker(m, "j1", {"--liveness", "150"});
  const fs::path out = root_ / "joined";
  const std::string id = Submit(m, MakeSession(out));
  ASSERT_TRUE(WaitFor(m, id, [](const auto& st) { return st.jobs_done() >= 3; }));
  first->Signal(SIGSTOP);
  // A result the first worker sent before it stopped is counted by now.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const int done_before = Status(m, id).jobs_done();
  auto second = StartWorker(m, "j2");
  const bool second_ran = WaitFor(m, id, [&](const auto& st) { return st.jobs_done() > done_before; });
  first->Signal(SIGCONT);
  ASSERT_TRUE(second_ran) << m.process->Log();
  const auto final = WaitForEnd(m, id);
  ASSERT_EQ(final.state(), "done") << final.error() << m.process->Log();
  ExpectSameOutputs(reference_, out);
  const std::string log = m.process->Log();
  EXPECT_NE(log.find("worker j2 joined"), std::string::npos) << log;
  EXPECT_EQ(CountOf(log, " joined ("), 2) << log;
  const std::string report = io::ReadFileBytes(out / "report.json");
  const int by_first = ReportInt(report, "j1"), by_second = ReportInt(report, "j2");
  EXPECT_GE(by_first, done_before) << report;
  EXPECT_GT(by_second, 0) << report;
  // Every worker job ran once: the surface is the master's own stage.
  EXPECT_EQ(by_first + by_second + int(instants_.size()), final.jobs_total()) << report;
}

TEST_F(Faults, ARestartedMasterResumesItsSessionsByItselfAndWatchGoesOn) {
  const fs::path state = root_ / "state";
  // The first master's ports are the kernel's choice; the second binds the same ones.
  Master m1 = StartMaster("master_state1", {"--state", state.string()});
  const std::string workers = m1.workers, control = m1.control, events = m1.events;
  auto w = StartWorker(m1, "s1");
  const fs::path out = root_ / "state_out";
  const std::string id = Submit(m1, MakeSession(out));
  ChildProcess watch("dome", {"watch", id, "--master", control, "--events", events, "--insecure"},
                     (root_ / "state_watch.log").string());
  ASSERT_TRUE(WaitFor(m1, id, [](const auto& st) { return st.instants(0).done(); }));
  m1.process->Kill();
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the watch notices
  // Nobody submits again: the new master on the same state folder resumes the session
  // under its id, and the watch (and the worker) find it where it was.
  Master m2 = StartMaster("master_state2", {"--state", state.string()}, workers, control, events);
  const auto final = WaitForEnd(m2, id);
  ASSERT_EQ(final.state(), "done") << final.error() << m2.process->Log();
  ExpectSameOutputs(reference_, out);
  EXPECT_NE(m2.process->Log().find("1 sessions known, 1 resumed"), std::string::npos)
      << m2.process->Log();
  EXPECT_NE(m2.process->Log().find("session " + id + ": resumed from "), std::string::npos)
      << m2.process->Log();
  // The watch started on the first master ends with the second's final status.
  EXPECT_EQ(watch.Wait(), 0) << watch.Log();
  EXPECT_NE(watch.Log().find("session " + id + "  done"), std::string::npos) << watch.Log();
  // A third master lists the ended session as it ended, and resumes nothing.
  m2.process->Stop();
  Master m3 = StartMaster("master_state3", {"--state", state.string()});
  EXPECT_EQ(Status(m3, id).state(), "done");
  EXPECT_NE(m3.process->Log().find("1 sessions known, 0 resumed"), std::string::npos)
      << m3.process->Log();
}

}  // namespace
}  // namespace dome
