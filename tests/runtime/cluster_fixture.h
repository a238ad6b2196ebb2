// Test fixture for the runtime with real processes on loopback (cluster_test.cc,
// fault_test.cc): the small synthetic take with two instants, the embedded `dome run`
// outputs every run must match byte for byte, and helpers that start dome-master and
// dome-worker processes and drive the master's control socket.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>
#include <zmq.hpp>

#include "cli/client.h"
#include "io/file_util.h"
#include "pipeline/session.h"
#include "runtime/process.h"
#include "testing/run_command.h"

namespace dome::testing {

// Small voxels' worth of slabs: enough jobs per instant (about 20 fusion slabs of the
// derived volume) that the fault tests can act while a session runs.
// Without silhouettes: these tests compare the runtime with the offline commands, which
// take no masks.
inline const std::vector<std::string> kSessionFlags = {"--voxel-mm", "40", "--slab-planes", "5",
                                                       "--no-masks"};

inline std::string Join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += " " + x;
  return s;
}

// Every output file under `dir` (client::SessionOutputFiles), relative path -> bytes.
inline std::map<std::string, std::string> Outputs(const std::filesystem::path& dir) {
  return client::SessionOutputFiles(dir);
}

inline void ExpectSameOutputs(const std::filesystem::path& reference,
                              const std::filesystem::path& out) {
  const auto a = Outputs(reference), b = Outputs(out);
  ASSERT_EQ(a.size(), b.size()) << out;
  for (const auto& [rel, bytes] : a) {
    auto it = b.find(rel);
    ASSERT_NE(it, b.end()) << rel << " missing in " << out;
    EXPECT_TRUE(it->second == bytes) << rel << " differs in " << out;
  }
}

// How many times `needle` occurs in `text`.
inline int CountOf(const std::string& text, const std::string& needle) {
  int n = 0;
  for (auto p = text.find(needle); p != std::string::npos; p = text.find(needle, p + 1)) ++n;
  return n;
}

class ClusterFixture : public ::testing::Test {
 protected:
  inline static std::filesystem::path root_, take_, reference_;
  inline static std::vector<std::string> instants_;

  static void SetUpTestSuite() {
    namespace fs = std::filesystem;
    root_ = fs::temp_directory_path() / ("dome_runtime_test_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
    take_ = root_ / "take";
    reference_ = root_ / "reference";
    const auto synth = RunDomeBinary("synth --preset small --instants 2 --out " + take_.string());
    ASSERT_EQ(synth.exit_code, 0) << synth.output;
    const auto run = RunDomeBinary("run " + take_.string() + " --out " + reference_.string() +
                                   " --workers 2 --threads 1" + Join(kSessionFlags));
    ASSERT_EQ(run.exit_code, 0) << run.output;
    for (const auto& e : fs::directory_iterator(take_ / "frames")) {
      instants_.push_back(e.path().filename().string());
    }
    std::sort(instants_.begin(), instants_.end());
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    std::filesystem::remove_all(root_, ec);
  }

  // `defaults` (flag, value) then `extra`, less the defaults whose flag `extra` gives (the
  // programs refuse a flag given twice).
  static std::vector<std::string> WithDefaults(
      const std::vector<std::pair<std::string, std::string>>& defaults,
      const std::vector<std::string>& extra) {
    std::vector<std::string> args;
    for (const auto& [flag, value] : defaults) {
      if (std::find(extra.begin(), extra.end(), flag) != extra.end()) continue;
      args.push_back(flag);
      args.push_back(value);
    }
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  }

  // A master on loopback with fast heartbeats (200 ms, liveness 3); endpoints read back
  // from its file. `workers` is its worker endpoint: a restarted master binds the port
  // its workers know.
  struct Master {
    std::unique_ptr<ChildProcess> process;
    std::string workers, control, events;
  };
  Master StartMaster(const std::string& name, std::vector<std::string> extra = {},
                     const std::string& workers = "tcp://127.0.0.1:*",
                     const std::string& control = "tcp://127.0.0.1:*",
                     const std::string& events = "tcp://127.0.0.1:*") {
    namespace fs = std::filesystem;
    Master m;
    const fs::path file = root_ / (name + ".endpoints");
    fs::remove(file);
    std::vector<std::string> args =
        WithDefaults({{"--bind", workers}, {"--control", control}, {"--events", events},
                      {"--heartbeat-ms", "200"}, {"--liveness", "3"},
                      {"--endpoints-file", file.string()}},
                     extra);
    // Plaintext unless the test gives keys (--keys DIR).
    if (std::find(extra.begin(), extra.end(), "--keys") == extra.end())
      args.push_back("--insecure");
    m.process =
        std::make_unique<ChildProcess>("dome-master", args, (root_ / (name + ".log")).string());
    for (int i = 0; i < 500 && !fs::exists(file); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    std::istringstream in(io::ReadFileBytes(file));
    in >> m.workers >> m.control >> m.events;
    return m;
  }
  std::unique_ptr<ChildProcess> StartWorker(const Master& m, const std::string& name,
                                            std::vector<std::string> extra = {}) {
    std::vector<std::string> args =
        WithDefaults({{"--master", m.workers}, {"--threads", "1"}, {"--cache-mb", "256"},
                      {"--heartbeat-ms", "200"}, {"--liveness", "3"}, {"--name", name}},
                     extra);
    // Plaintext unless the test gives keys (--master-key FILE --key FILE).
    if (std::find(extra.begin(), extra.end(), "--key") == extra.end()) args.push_back("--insecure");
    return std::make_unique<ChildProcess>("dome-worker", args, (root_ / (name + ".log")).string());
  }

  // The reference run's session (REFERENCE/session.json: kSessionFlags and what `dome
  // run` derived from the take) writing to `out`: the same jobs, the same outputs.
  runtime::Session MakeSession(const std::filesystem::path& out) {
    runtime::Session s = pipeline::ReadSessionJson(reference_ / "session.json");
    s.set_out(out.string());
    s.clear_derived();
    return s;
  }
  std::string Submit(const Master& m, const runtime::Session& s) {
    runtime::ControlRequest req;
    *req.mutable_submit()->mutable_session() = s;
    return client::Request(&context_, m.control, req).session_id();
  }
  runtime::SessionStatus Status(const Master& m, const std::string& id) {
    runtime::ControlRequest req;
    req.mutable_status()->set_session_id(id);
    return client::Request(&context_, m.control, req).sessions(0);
  }
  // Polls until `pred(status)` or the session ends; true when pred held.
  template <typename Pred>
  bool WaitFor(const Master& m, const std::string& id, Pred pred, double timeout_s = 60) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < end) {
      const auto st = Status(m, id);
      if (pred(st)) return true;
      if (st.state() != "running") return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return false;
  }
  // Waits until the session is no longer running; its final status.
  runtime::SessionStatus WaitForEnd(const Master& m, const std::string& id,
                                    double timeout_s = 120) {
    WaitFor(
        m, id, [](const auto&) { return false; }, timeout_s);
    return Status(m, id);
  }
  static int Done(const runtime::SessionStatus& st, int instant, const std::string& stage) {
    for (const auto& s : st.instants(instant).stages()) {
      if (s.stage() == stage) return s.done();
    }
    return -1;
  }

  zmq::context_t context_;
};

}  // namespace dome::testing
