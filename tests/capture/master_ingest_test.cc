// Capture into the master, as deployed: a dome-master hosting the frame ingest
// (--capture-bind, --take) and two dome-capture agents with simulated decks on the
// small synthetic take's tapes, each a separate process. The master's take must hold
// every wanted frame once, pixel for pixel the rendered first field; a SUB on the
// master's status socket must see each camera's progress reach the whole range; a
// master killed (SIGKILL) and started again during the capture must lose nothing.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>
#include <zmq.hpp>

#include "io/file_util.h"
#include "io/image_io.h"
#include "net/events.h"
#include "net/security.h"
#include "runtime.pb.h"
#include "runtime/process.h"
#include "synth/synth.h"
#include "synth_tapes_fixture.h"
#include "testing/temp_dir.h"

namespace dome::capture {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using dome::testing::ChildProcess;

// The master's four endpoints. By default every port is the kernel's choice (":*"),
// read back from what the master prints once bound: a port picked free beforehand could
// be taken by a test running beside this one before the master binds it. A restarted
// master is given the ports its predecessor printed, so its agents find it again.
struct MasterPorts {
  std::string workers = "tcp://127.0.0.1:*", control = "tcp://127.0.0.1:*",
              events = "tcp://127.0.0.1:*", capture = "tcp://127.0.0.1:*";
};

// The endpoint printed after `label ` on a line of `log`, or "" while there is none.
std::string PrintedEndpoint(const std::string& log, const std::string& label) {
  const std::string key = label + " tcp://";
  for (size_t at = log.find(key); at != std::string::npos; at = log.find(key, at + 1)) {
    if (at != 0 && log[at - 1] != '\n') continue;
    const size_t begin = at + label.size() + 1, end = log.find('\n', begin);
    if (end == std::string::npos) return "";  // the line is not complete yet
    return log.substr(begin, end - begin);
  }
  return "";
}

// dome-master with a capture ingest; the constructor returns once it prints its
// capture endpoint (it has bound every socket), and ports() are the bound endpoints.
class MasterProcess {
 public:
  // `security`: the key flags, or --insecure.
  MasterProcess(const MasterPorts& ports, const fs::path& take, const std::string& log,
                const std::vector<std::string>& security = {"--insecure"})
      : process_("dome-master", MasterArgs(ports, take, security), log) {
    const auto end = Clock::now() + std::chrono::seconds(20);
    while (Clock::now() < end && PrintedEndpoint(process_.Log(), "capture").empty()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    const std::string printed = process_.Log();
    bound_ = {PrintedEndpoint(printed, "workers"), PrintedEndpoint(printed, "control"),
              PrintedEndpoint(printed, "events"), PrintedEndpoint(printed, "capture")};
    up_ = !bound_.capture.empty();
  }
  bool up() const { return up_; }
  const MasterPorts& ports() const { return bound_; }
  ChildProcess& process() { return process_; }

 private:
  static std::vector<std::string> MasterArgs(const MasterPorts& ports, const fs::path& take,
                                             const std::vector<std::string>& security) {
    std::vector<std::string> args = {"--bind",   ports.workers, "--control",      ports.control,
                                     "--events", ports.events,  "--capture-bind", ports.capture,
                                     "--take",   take.string()};
    args.insert(args.end(), security.begin(), security.end());
    return args;
  }

  ChildProcess process_;
  MasterPorts bound_;
  bool up_ = false;
};

// Collects the capture StatusEvents the master publishes, on its own thread.
class CaptureEventWatcher {
 public:
  explicit CaptureEventWatcher(const std::string& events) {
    thread_ = std::thread([this, events] {
      net::EventSubscription subscription(&context_, events, net::SocketOptions{});
      while (!stop_) {
        subscription.Drain(20, [this](const runtime::StatusEvent& ev) {
          if (!ev.has_capture()) return;
          std::lock_guard lock(mutex_);
          events_[ev.capture().camera_id()].push_back(ev.capture());
        });
      }
    });
    // A subscriber joins a moment after connecting; events before that are lost (by
    // design).
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  ~CaptureEventWatcher() {
    stop_ = true;
    thread_.join();
  }
  std::vector<runtime::CaptureStatus> EventsOf(const std::string& camera) {
    std::lock_guard lock(mutex_);
    return events_[camera];
  }
  // Waits until `camera` has reported the end of its capture.
  bool WaitForDone(const std::string& camera, std::chrono::seconds timeout) {
    const auto end = Clock::now() + timeout;
    while (Clock::now() < end) {
      for (const auto& e : EventsOf(camera)) {
        if (e.state() != "capturing") return true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }

 private:
  zmq::context_t context_;
  std::mutex mutex_;
  std::map<std::string, std::vector<runtime::CaptureStatus>> events_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

class MasterIngest : public test_tapes::SmallTakeWithTapes {
 protected:
  // One agent; `extra` adds flags (pace, bandwidth).
  static std::unique_ptr<ChildProcess> StartAgent(
      const std::string& camera, const std::string& master, const fs::path& work,
      std::vector<std::string> extra, std::vector<std::string> security = {"--insecure"}) {
    std::vector<std::string> args = {
        "--camera",         camera,
        "--deck",           "sim:" + (Synth() / "tape" / (camera + ".avi")).string(),
        "--digitizer",      "sim",
        "--range",          Range(),
        "--every",          "5",
        "--master",         master,
        "--spool",          (work / ("spool-" + camera)).string(),
        "--ack-timeout-ms", "300",
    };
    args.insert(args.end(), extra.begin(), extra.end());
    args.insert(args.end(), security.begin(), security.end());
    return std::make_unique<ChildProcess>("dome-capture", args,
                                          (work / ("agent-" + camera + ".log")).string());
  }

  // Every wanted frame of `camera` in `take`, identical to the synthetic take's image,
  // and no frame of it under any other instant.
  static void ExpectTakeEqualsSynth(const fs::path& take, const std::string& camera) {
    ExpectFramesEqualSynth(take, camera);
    int files = 0;
    for (const auto& e : fs::recursive_directory_iterator(take / "frames")) {
      files += e.is_regular_file() && e.path().filename() == camera + ".png";
    }
    EXPECT_EQ(files, Wanted()) << camera << ": frames in " << take;
  }

  static int FramesIn(const fs::path& take) {
    int n = 0;
    if (!fs::exists(take / "frames")) return 0;
    for (const auto& e : fs::recursive_directory_iterator(take / "frames"))
      n += e.path().extension() == ".png";
    return n;
  }
};

const std::vector<std::string> kCameras = {"c00", "c01"};

TEST_F(MasterIngest, AgentsCaptureIntoTheMastersTakeAndItsStatusEventsShowProgress) {
  dome::testing::TempDir work;
  MasterProcess master(MasterPorts{}, work / "take", work.File("master.log"));
  ASSERT_TRUE(master.up()) << master.process().Log();
  const MasterPorts ports = master.ports();
  CaptureEventWatcher watcher(ports.events);
  std::vector<std::unique_ptr<ChildProcess>> agents;
  for (const auto& camera : kCameras) {
    // One frame in three kept: more than one pass, so the pass number moves.
    agents.push_back(StartAgent(camera, ports.capture, work.path(), {"--keep-per-second", "10"}));
  }
  for (size_t i = 0; i < agents.size(); ++i) {
    EXPECT_EQ(agents[i]->Wait(), 0) << agents[i]->Log();
    EXPECT_NE(agents[i]->Log().find("captured " + std::to_string(Wanted()) + " of " +
                                    std::to_string(Wanted()) + " frames"),
              std::string::npos)
        << agents[i]->Log();
  }
  for (const auto& camera : kCameras) {
    ExpectTakeEqualsSynth(work / "take", camera);
    ASSERT_TRUE(watcher.WaitForDone(camera, std::chrono::seconds(10))) << camera;
    const auto events = watcher.EventsOf(camera);
    const runtime::CaptureStatus& last = events.back();
    EXPECT_EQ(last.state(), "complete") << last.DebugString();
    EXPECT_EQ(last.captured(), Wanted());
    EXPECT_EQ(last.wanted(), Wanted());
    EXPECT_EQ(last.acknowledged(), Wanted());
    EXPECT_EQ(last.stored(), Wanted());  // each frame stored once, no duplicates written
    EXPECT_TRUE(last.error().empty()) << last.error();
    EXPECT_GE(last.pass(), 1);
    // Progress never goes backwards, and the pass yields add up to what was captured.
    int captured = 0, pass = 0;
    std::map<int, int> yield_of_pass;
    for (const auto& e : events) {
      EXPECT_GE(e.captured(), captured) << e.DebugString();
      EXPECT_GE(e.pass(), pass) << e.DebugString();
      EXPECT_LE(e.captured(), e.wanted()) << e.DebugString();
      captured = e.captured();
      pass = e.pass();
      yield_of_pass[e.pass()] = e.pass_yield();
    }
    int total_yield = 0;
    for (const auto& [p, y] : yield_of_pass) total_yield += y;
    EXPECT_EQ(total_yield, Wanted()) << camera;
  }
  EXPECT_EQ(master.process().Stop(), 0) << master.process().Log();
}

TEST_F(MasterIngest, MasterKilledAndRestartedDuringCaptureLosesNothing) {
  dome::testing::TempDir work;
  auto master =
      std::make_unique<MasterProcess>(MasterPorts{}, work / "take", work.File("master1.log"));
  ASSERT_TRUE(master->up()) << master->process().Log();
  const MasterPorts ports = master->ports();  // the restarted master binds these again
  CaptureEventWatcher watcher(ports.events);
  std::vector<std::unique_ptr<ChildProcess>> agents;
  for (const auto& camera : kCameras) {
    // Decks at twice real time (a cue-up winds for one second) and a digitizer keeping
    // two frames a second: a capture of several passes, seconds long.
    agents.push_back(StartAgent(camera, ports.capture, work.path(),
                                {"--sim-pace", "2", "--keep-per-second", "2"}));
  }
  // The first frame stored: the capture is under way. Kill the master mid-capture.
  const auto end = Clock::now() + std::chrono::seconds(20);
  while (FramesIn(work / "take") == 0 && Clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  master->process().Kill();
  const int before = FramesIn(work / "take");
  ASSERT_LT(before, Wanted() * static_cast<int>(kCameras.size()))
      << "the capture ended before the master was killed";
  std::this_thread::sleep_for(std::chrono::milliseconds(800));  // agents capture on, spooling
  master = std::make_unique<MasterProcess>(ports, work / "take", work.File("master2.log"));
  ASSERT_TRUE(master->up()) << master->process().Log();

  int64_t stored_after_restart = 0;
  for (size_t i = 0; i < agents.size(); ++i) {
    EXPECT_EQ(agents[i]->Wait(), 0) << agents[i]->Log();
    ExpectTakeEqualsSynth(work / "take", kCameras[i]);
    // The final progress is acknowledged, so the restarted master always hears it.
    ASSERT_TRUE(watcher.WaitForDone(kCameras[i], std::chrono::seconds(10))) << kCameras[i];
    const runtime::CaptureStatus last = watcher.EventsOf(kCameras[i]).back();
    EXPECT_EQ(last.state(), "complete") << last.DebugString();
    EXPECT_EQ(last.captured(), Wanted());
    stored_after_restart += last.stored();  // counted by the restarted master only
  }
  // Frames reached the take after the restart: the capture went on across it.
  EXPECT_GT(stored_after_restart, 0);
  EXPECT_EQ(before + stored_after_restart, static_cast<int64_t>(Wanted() * kCameras.size()))
      << "frames stored by the first master before the kill plus those stored by the "
         "second must be every frame, once";
  EXPECT_EQ(master->process().Stop(), 0) << master->process().Log();
}

TEST_F(MasterIngest, ASecureMasterTakesFramesOnlyFromAgentsOnItsAllowList) {
  dome::testing::TempDir work;
  const std::string keys = work.File("keys");
  fs::create_directories(keys);
  net::WriteKeyPair(keys + "/master", net::GenerateKeyPair());
  net::WriteKeyPair(keys + "/allowed", net::GenerateKeyPair(), "capture");
  net::WriteKeyPair(keys + "/stranger", net::GenerateKeyPair(), "capture");
  io::WriteFileAtomically(keys + "/allowed_keys", io::ReadFileBytes(keys + "/allowed.pub"));
  MasterProcess master(MasterPorts{}, work / "take", work.File("master.log"),
                       {"--secret-key", keys + "/master.key", "--allow", keys + "/allowed_keys"});
  ASSERT_TRUE(master.up()) << master.process().Log();
  const MasterPorts ports = master.ports();
  auto allowed = StartAgent("c00", ports.capture, work.path(), {},
                            {"--master-key", keys + "/master.pub", "--key", keys + "/allowed.key"});
  auto stranger =
      StartAgent("c01", ports.capture, work.path(), {"--flush-timeout-ms", "1500"},
                 {"--master-key", keys + "/master.pub", "--key", keys + "/stranger.key"});
  EXPECT_EQ(allowed->Wait(), 0) << allowed->Log();
  ExpectTakeEqualsSynth(work / "take", "c00");
  // The stranger captures, but the master never lets its frames in: they stay spooled.
  EXPECT_EQ(stranger->Wait(), 1) << stranger->Log();
  EXPECT_NE(stranger->Log().find("still in the spool"), std::string::npos) << stranger->Log();
  EXPECT_FALSE(fs::exists(work / "take" / "frames" / summary_->instants[0] / "c01.png"));
  // A plaintext agent gets nothing in either.
  auto plain = StartAgent("c02", ports.capture, work.path(), {"--flush-timeout-ms", "1500"});
  EXPECT_EQ(plain->Wait(), 1) << plain->Log();
  EXPECT_FALSE(fs::exists(work / "take" / "frames" / summary_->instants[0] / "c02.png"));
  EXPECT_EQ(master.process().Stop(), 0) << master.process().Log();
}

}  // namespace
}  // namespace dome::capture
