// Conditions that must end a session in a named state rather than leave it running
// (real processes on loopback, real files, a real small tmpfs where this machine lets
// the test mount one): a full disk under the outputs or under the journal, a take file
// deleted or replaced mid-session, a worker cache smaller than a job's inputs, a worker
// that heartbeats but never finishes a job, a worker that only sends bad results, a
// volume no worker job can hold. Each asserts the end state and the message; where the
// fault goes away, the run that follows ends with the undisturbed run's bytes.
#include <gtest/gtest.h>
#include <sys/mount.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <string>
#include <thread>

#include "core/error.h"
#include "io/file_util.h"
#include "net/wire.h"
#include "runtime/cluster_fixture.h"
#include "runtime/process.h"
#include "testing/run_command.h"

namespace dome {
namespace {
namespace fs = std::filesystem;
using testing::ExpectSameOutputs;
using testing::Join;
using testing::RunDomeBinary;

// A tmpfs of `size` (mount's syntax: "2m", "8k") at `dir`, unmounted when it goes;
// mounted() is false where the test may not mount (not root, no CAP_SYS_ADMIN).
class SmallDisk {
 public:
  SmallDisk(const fs::path& dir, const std::string& size) : dir_(dir) {
    fs::create_directories(dir);
    mounted_ = ::mount("tmpfs", dir.c_str(), "tmpfs", 0, ("size=" + size).c_str()) == 0;
  }
  ~SmallDisk() {
    if (mounted_) ::umount2(dir_.c_str(), MNT_DETACH);
  }
  bool mounted() const { return mounted_; }

 private:
  fs::path dir_;
  bool mounted_ = false;
};

// A peer on the master's worker socket that says Hello and heartbeats like a worker,
// and answers each job with `answer` (nothing: it never finishes one).
class FakeWorker {
 public:
  using Answer = std::function<std::optional<runtime::JobResult>(const runtime::Job&)>;
  FakeWorker(zmq::context_t* context, const std::string& endpoint, Answer answer)
      : socket_(*context, zmq::socket_type::dealer), answer_(std::move(answer)) {
    socket_.set(zmq::sockopt::linger, 0);
    socket_.connect(endpoint);
    runtime::Envelope hello;
    hello.mutable_hello()->set_name("fake");
    hello.mutable_hello()->set_threads(1);
    hello.mutable_hello()->set_cache_mb(1024);
    Send(hello);
    thread_ = std::thread([this] { Loop(); });
  }
  ~FakeWorker() {
    stop_ = true;
    thread_.join();
  }
  int jobs() const { return jobs_; }

 private:
  void Send(const runtime::Envelope& env) {
    const std::string bytes = net::EncodeEnvelope(env);
    socket_.send(zmq::buffer(bytes), zmq::send_flags::none);
  }
  void Loop() {
    auto next = std::chrono::steady_clock::now();
    while (!stop_) {
      zmq::message_t msg;
      while (socket_.recv(msg, zmq::recv_flags::dontwait)) {
        runtime::Envelope env;
        if (!env.ParseFromArray(msg.data(), int(msg.size())) || !env.has_job()) continue;
        ++jobs_;
        if (auto result = answer_(env.job())) {
          runtime::Envelope reply;
          *reply.mutable_result() = *result;
          Send(reply);
        }
      }
      if (std::chrono::steady_clock::now() >= next) {
        runtime::Envelope hb;
        hb.mutable_heartbeat();
        Send(hb);
        next += std::chrono::milliseconds(100);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
  zmq::socket_t socket_;
  Answer answer_;
  std::atomic<bool> stop_{false};
  std::atomic<int> jobs_{0};
  std::thread thread_;
};

class NeverHang : public testing::ClusterFixture {
 protected:
  // A copy of the take this test may change.
  fs::path CopyTake(const std::string& name) {
    const fs::path copy = root_ / name;
    fs::remove_all(copy);
    fs::copy(take_, copy, fs::copy_options::recursive);
    return copy;
  }
  // The frame of the last instant of the first camera in the copy `take`.
  fs::path LastInstantFrame(const fs::path& take) {
    fs::path first;
    for (const auto& e : fs::directory_iterator(take / "frames" / instants_.back())) {
      if (first.empty() || e.path() < first) first = e.path();
    }
    return first;
  }
  std::string RunFlags(const fs::path& take, const fs::path& out) {
    return "run " + take.string() + " --out " + out.string() + " --workers 2 --threads 1" +
           Join(testing::kSessionFlags);
  }
};

TEST_F(NeverHang, AFullDiskUnderTheOutputsFailsTheSessionNamingTheFile) {
  const fs::path disk = root_ / "full_disk";
  SmallDisk small(disk, "2m");
  if (!small.mounted()) GTEST_SKIP() << "cannot mount a tmpfs here (needs root)";
  const auto run = RunDomeBinary(RunFlags(take_, disk / "out"));
  EXPECT_NE(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("failed"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("No space left on device"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find((disk / "out").string()), std::string::npos) << run.output;
}

TEST_F(NeverHang, AFullDiskUnderTheJournalFailsTheSessionAndAFreedOneFinishesIt) {
  // The journal alone on a disk of two pages, the outputs elsewhere: it fills after a
  // few dozen records.
  const fs::path disk = root_ / "journal_disk";
  SmallDisk small(disk, "8k");
  if (!small.mounted()) GTEST_SKIP() << "cannot mount a tmpfs here (needs root)";
  const fs::path out = root_ / "journal_full";
  fs::create_directories(out);
  fs::create_symlink(disk / "journal.log", out / "journal.log");
  const auto run = RunDomeBinary(RunFlags(take_, out));
  EXPECT_NE(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find((out / "journal.log").string() + ": cannot append a record: "
                                                             "No space left on device"),
            std::string::npos)
      << run.output;
  // Space again (the journal back on the output disk): the same command finishes, with
  // the bytes of the undisturbed run.
  fs::remove(out / "journal.log");
  const auto again = RunDomeBinary(RunFlags(take_, out));
  ASSERT_EQ(again.exit_code, 0) << again.output;
  ExpectSameOutputs(reference_, out);
}

TEST_F(NeverHang, ATakeFileDeletedMidSessionFailsItNamingTheFile) {
  const fs::path take = CopyTake("take_deleted");
  Master m = StartMaster("master_deleted");
  auto w1 = StartWorker(m, "d1");
  auto w2 = StartWorker(m, "d2");
  runtime::Session session = MakeSession(root_ / "deleted");
  session.set_take(take.string());
  const std::string id = Submit(m, session);
  // The master read every frame at submit; the last instant's are served later.
  const fs::path frame = LastInstantFrame(take);
  fs::remove(frame);
  const auto final = WaitForEnd(m, id, 60);
  ASSERT_EQ(final.state(), "failed") << m.process->Log();
  EXPECT_NE(final.error().find("take file " + frame.string() + ": no such file"), std::string::npos)
      << final.error();
}

// A frame of the last instant that is empty or not a PNG: the master reads every
// frame at submit and refuses the session there, naming the file, before any job runs
// and without making the output folder (it was found only by the stereo job decoding
// it, 30-50 jobs in).
TEST_F(NeverHang, AnEmptyOrNonPngFrameOfTheLastInstantIsRefusedAtSubmit) {
  const fs::path take = CopyTake("take_bad_frame");
  const fs::path frame = LastInstantFrame(take);
  Master m = StartMaster("master_bad_frame");
  const struct {
    std::string bytes;
    std::string message;
  } cases[] = {{"", "empty file (0 bytes), expected a PNG"},
               {"GIF89a, not a PNG", "not a PNG (it does not start with the PNG signature)"}};
  for (const auto& c : cases) {
    io::WriteFileAtomically(frame, c.bytes);
    runtime::Session session = MakeSession(root_ / "bad_frame");
    session.set_take(take.string());
    std::string error;
    try {
      Submit(m, session);
    } catch (const core::InputError& e) {
      error = e.what();
    }
    EXPECT_NE(error.find(frame.string() + ": " + c.message), std::string::npos) << error;
    EXPECT_FALSE(fs::exists(root_ / "bad_frame")) << c.message;
  }
}

TEST_F(NeverHang, ATakeFileReplacedMidSessionFailsItNamingTheFile) {
  const fs::path take = CopyTake("take_replaced");
  Master m = StartMaster("master_replaced");
  auto w1 = StartWorker(m, "p1");
  runtime::Session session = MakeSession(root_ / "replaced");
  session.set_take(take.string());
  const std::string id = Submit(m, session);
  const fs::path frame = LastInstantFrame(take);
  const fs::path other = take / "frames" / instants_.front() / frame.filename();
  fs::copy_file(other, frame, fs::copy_options::overwrite_existing);
  const auto final = WaitForEnd(m, id, 60);
  ASSERT_EQ(final.state(), "failed") << m.process->Log();
  EXPECT_NE(
      final.error().find("take file " + frame.string() + ": changed since it was read at submit"),
      std::string::npos)
      << final.error();
  // No worker asked for it without end: the master never served the new bytes.
  EXPECT_EQ(w1->Log().find("does not hash to its address"), std::string::npos) << w1->Log();
}

TEST_F(NeverHang, AWorkerCacheSmallerThanAJobsInputsFailsTheSessionWithTheSizes) {
  const auto zero =
      RunDomeBinary("--master tcp://127.0.0.1:1 --cache-mb 0 --insecure", "dome-worker");
  EXPECT_NE(zero.exit_code, 0);
  EXPECT_NE(zero.output.find("--cache-mb: must be at least 1 MiB"), std::string::npos)
      << zero.output;
  // Frames of 1 MB and more: a stereo job's inputs do not fit in one MiB.
  const fs::path take = root_ / "take_large";
  const auto synth = RunDomeBinary(
      "synth --preset small --instants 1 --width 800 --height 600 "
      "--no-tape --no-calib --out " +
      take.string());
  ASSERT_EQ(synth.exit_code, 0) << synth.output;
  Master m = StartMaster("master_cache");
  testing::ChildProcess w("dome-worker",
                          {"--master", m.workers, "--threads", "1", "--cache-mb", "1",
                           "--heartbeat-ms", "200", "--name", "c1", "--insecure"},
                          (root_ / "c1.log").string());
  runtime::Session session = MakeSession(root_ / "cache");
  session.set_take(take.string());
  session.clear_instants();
  const std::string id = Submit(m, session);
  const auto final = WaitForEnd(m, id, 60);
  ASSERT_EQ(final.state(), "failed") << m.process->Log();
  EXPECT_NE(final.error().find("MiB of inputs at once, more than the blob cache of any worker "
                               "connected (largest: 1 MiB; dome-worker --cache-mb)"),
            std::string::npos)
      << final.error();
}

TEST_F(NeverHang, AJobThatNeverFinishesTimesOutAndRunsElsewhere) {
  Master m = StartMaster("master_timeout", {"--job-timeout-s", "1"});
  FakeWorker silent(&context_, m.workers, [](const runtime::Job&) { return std::nullopt; });
  const fs::path out = root_ / "timeout";
  const std::string id = Submit(m, MakeSession(out));
  // The silent peer takes the first jobs; past a second each is dropped and re-queued.
  ASSERT_TRUE(WaitFor(
      m, id, [&](const auto&) { return silent.jobs() >= 1; }, 30));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  auto w = StartWorker(m, "t1");
  const auto final = WaitForEnd(m, id, 120);
  ASSERT_EQ(final.state(), "done") << final.error() << m.process->Log();
  ExpectSameOutputs(reference_, out);
  EXPECT_NE(m.process->Log().find("worker fake ("), std::string::npos) << m.process->Log();
  EXPECT_NE(m.process->Log().find("did not finish job " + id + "/"), std::string::npos)
      << m.process->Log();
}

TEST_F(NeverHang, OnlyAWorkerThatNeverFinishesFailsTheSessionAfterBoundedTimeOuts) {
  Master m = StartMaster("master_timeout_only", {"--job-timeout-s", "0.5"});
  FakeWorker silent(&context_, m.workers, [](const runtime::Job&) { return std::nullopt; });
  const std::string id = Submit(m, MakeSession(root_ / "timeout_only"));
  const auto final = WaitForEnd(m, id, 60);
  ASSERT_EQ(final.state(), "failed") << m.process->Log();
  EXPECT_NE(final.error().find("was lost 5 times; the last time: worker fake ("), std::string::npos)
      << final.error();
  EXPECT_NE(final.error().find("within its time-out of 0.5 s"), std::string::npos) << final.error();
}

TEST_F(NeverHang, AWorkerSendingOnlyBadResultsFailsTheSessionAfterBoundedRetries) {
  Master m = StartMaster("master_bad_results");
  // A result the stage cannot read (stereo expects its range images).
  FakeWorker bad(&context_, m.workers, [](const runtime::Job& job) {
    runtime::JobResult r;
    r.set_job_id(job.id());
    r.set_ok(true);
    r.add_outputs()->set_name("nonsense");
    return std::optional<runtime::JobResult>(r);
  });
  const std::string id = Submit(m, MakeSession(root_ / "bad_results"));
  const auto final = WaitForEnd(m, id, 60);
  ASSERT_EQ(final.state(), "failed") << m.process->Log();
  EXPECT_NE(final.error().find("was lost 5 times; the last time: worker fake ("), std::string::npos)
      << final.error();
  EXPECT_NE(final.error().find("sent a bad result ("), std::string::npos) << final.error();
}

TEST_F(NeverHang, AVolumeNoWorkerJobCanHoldIsRefusedAtSubmitLeavingNothing) {
  Master m = StartMaster("master_huge", {"--max-job-mb", "4096"});
  const fs::path out = root_ / "huge";
  runtime::Session session = MakeSession(out);
  session.mutable_volume()->clear_dims();
  session.mutable_volume()->add_dims(46000);
  session.mutable_volume()->add_dims(46000);
  session.mutable_volume()->add_dims(100000);
  runtime::ControlRequest req;
  *req.mutable_submit()->mutable_session() = session;
  std::string error;
  try {
    client::Request(&context_, m.control, req);
  } catch (const core::InputError& e) {
    error = e.what();
  }
  EXPECT_NE(error.find("a fusion job of 46000 x 46000 voxels x 5 planes needs 80719 MiB, "
                       "more than the 4096 MiB a worker job may use"),
            std::string::npos)
      << error;
  EXPECT_FALSE(fs::exists(out)) << "a refused submit creates nothing";
}

TEST_F(NeverHang, AResultOverTheMessageCapFailsTheSessionSayingSo) {
  // A depth map of the small take is about 150 KB on the wire.
  Master m = StartMaster("master_cap", {"--max-message-bytes", "100000"});
  auto w = StartWorker(m, "m1", {"--max-message-bytes", "100000"});
  const auto final = WaitForEnd(m, Submit(m, MakeSession(root_ / "cap")), 60);
  ASSERT_EQ(final.state(), "failed") << m.process->Log();
  EXPECT_NE(final.error().find("over the message cap of 100000 bytes (--max-message-bytes"),
            std::string::npos)
      << final.error();
}

// Submitting a take of thousands of instants reads and hashes every frame and builds a
// job graph of 84,000 jobs; that work runs beside the master's loop, which meanwhile
// keeps answering its workers: neither side finds the other silent (the graph built on
// the loop took it 0.3 s and more under load, past the workers' 600 ms liveness at
// times).
TEST_F(NeverHang, ASubmitOfThousandsOfInstantsKeepsTheWorkersConnected) {
  const int kInstants = 4000;  // about a second to plan here: past the workers' 600 ms liveness
  const fs::path big = root_ / "take_big";
  fs::create_directories(big / "frames");
  fs::copy_file(take_ / "rig.json", big / "rig.json");
  for (int n = 0; n < kInstants; ++n) {
    char name[16];
    std::snprintf(name, sizeof name, "00-%02d-%02d-%02d", n / 1500, n / 25 % 60, n % 25);
    fs::create_directories(big / "frames" / name);
    for (const auto& e : fs::directory_iterator(take_ / "frames" / instants_[0])) {
      fs::create_hard_link(e.path(), big / "frames" / name / e.path().filename());
    }
  }
  Master m = StartMaster("master_big");
  auto w = StartWorker(m, "b1");
  for (int i = 0; i < 200 && m.process->Log().find("worker b1 joined") == std::string::npos; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  runtime::Session session = MakeSession(root_ / "big");
  session.set_take(big.string());
  session.clear_instants();
  const auto start = std::chrono::steady_clock::now();
  const std::string id = Submit(m, session);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  runtime::ControlRequest cancel;
  cancel.mutable_cancel()->set_session_id(id);
  client::Request(&context_, m.control, cancel);
  std::printf("submit of 4000 instants: %.2f s\n", seconds);
  EXPECT_EQ(Status(m, id).state(), "cancelled");
  EXPECT_EQ(m.process->Log().find("lost (no heartbeat"), std::string::npos) << m.process->Log();
  EXPECT_EQ(w->Log().find("master silent"), std::string::npos) << w->Log();
}

// A master that runs for good: a session that ended closes its journal and lets go of
// its bookkeeping, so the master's open files do not grow with the sessions it ran
// (each ended session's journal stayed open before: 20 sessions, 20 more files).
TEST_F(NeverHang, EndedSessionsLeaveNoFileOpenInTheMaster) {
  Master m = StartMaster("master_files");
  auto w = StartWorker(m, "f1");
  const fs::path fd_dir = "/proc/" + std::to_string(m.process->pid()) + "/fd";
  auto open_files = [&] {
    return std::distance(fs::directory_iterator(fd_dir), fs::directory_iterator{});
  };
  runtime::Session noop;
  noop.set_noop_jobs(2);
  auto run = [&](int i) {
    noop.set_out((root_ / ("files" + std::to_string(i))).string());
    return WaitForEnd(m, Submit(m, noop)).state();
  };
  ASSERT_EQ(run(0), "done") << m.process->Log();  // the master's sockets and pools are up
  const auto before = open_files();
  for (int i = 1; i <= 20; ++i) ASSERT_EQ(run(i), "done") << i << "\n" << m.process->Log();
  // A client's connection may still be closing: a couple of files, not one a session.
  EXPECT_LE(open_files(), before + 2) << "before: " << before;
}

TEST_F(NeverHang, OutputFoldersOutsideTheOutRootAreRefusedCreatingNothing) {
  const fs::path allowed = root_ / "out_root";
  fs::create_directories(allowed);
  fs::create_symlink(root_, allowed / "escape");  // a link inside that points outside
  Master m = StartMaster("master_out_root", {"--out-root", allowed.string()});
  for (const fs::path& out :
       {root_ / "outside", allowed / ".." / "dotdot", allowed / "escape" / "x"}) {
    std::string error;
    try {
      Submit(m, MakeSession(out));
    } catch (const core::InputError& e) {
      error = e.what();
    }
    EXPECT_NE(error.find("session: out: '" + out.string() +
                         "' is outside the master's output "
                         "root " +
                         allowed.string() + " (dome-master --out-root)"),
              std::string::npos)
        << error;
    EXPECT_FALSE(fs::exists(out)) << out;
  }
  auto w = StartWorker(m, "o1");
  const fs::path inside = allowed / "a" / "b";
  const auto final = WaitForEnd(m, Submit(m, MakeSession(inside)), 120);
  EXPECT_EQ(final.state(), "done") << final.error();
  ExpectSameOutputs(reference_, inside);
}

// A master whose message cap is below its worker's: a depth map (about 150 KB) is over
// twice the master's 50,000 bytes, which its socket drops unread with the connection;
// the worker reconnected and the job counted as lost with it, five times, and the
// session failed as "lost (no heartbeat ...)". Each job carries the master's cap, so
// the worker reports the result as over it, and the session fails saying so.
TEST_F(NeverHang, AResultOverTheMastersCapBelowTheWorkersIsNamedAsSuch) {
  Master m = StartMaster("master_cap_below", {"--max-message-bytes", "50000"});
  auto w = StartWorker(m, "c1");  // its own cap: the default, 256 MiB
  const auto final = WaitForEnd(m, Submit(m, MakeSession(root_ / "cap_below")), 60);
  ASSERT_EQ(final.state(), "failed") << m.process->Log();
  EXPECT_NE(final.error().find(" bytes, over the message cap of 50000 bytes (--max-message-bytes"),
            std::string::npos)
      << final.error();
  EXPECT_EQ(m.process->Log().find("lost (no heartbeat"), std::string::npos) << m.process->Log();
}

// A worker whose message cap is below a job's input (the small take's frames are about
// 15 KB): the master's reply carrying it was refused by the worker (or, over twice its
// cap, dropped unread with the connection) and the worker waited for it: the session
// was still running 60 s later, left to the job time-outs. The worker checks each
// input's size against its cap when the job comes, and the session fails naming the
// input and the cap.
TEST_F(NeverHang, AnInputOverAWorkersMessageCapIsNamedAsSuch) {
  Master m = StartMaster("master_input_cap");
  auto w = StartWorker(m, "i1", {"--max-message-bytes", "10000"});
  const auto final = WaitForEnd(m, Submit(m, MakeSession(root_ / "input_cap")), 60);
  ASSERT_EQ(final.state(), "failed") << m.process->Log();
  EXPECT_NE(final.error().find(" bytes, over this worker's message cap of 10000 bytes with its "
                               "reply's framing (--max-message-bytes"),
            std::string::npos)
      << final.error();
  EXPECT_NE(final.error().find("its input frames/"), std::string::npos) << final.error();
}

}  // namespace
}  // namespace dome
