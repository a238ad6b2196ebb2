// The runtime end to end with real processes on loopback: dome-master, dome-worker
// processes and the dome client on the small synthetic take. Every run must produce
// the same bytes as the embedded `dome run`, which itself must match the offline
// `dome stereo` and `dome fuse` on the same inputs.
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <map>
#include <random>
#include <thread>
#include <zmq.hpp>

#include "client/client.h"
#include "io/file_util.h"
#include "io/ply.h"
#include "net/wire.h"
#include "runtime/process.h"
#include "testing/run_command.h"

namespace dome {
namespace {
namespace fs = std::filesystem;
using testing::ChildProcess;
using testing::RunDomeBinary;

// Small volume and slabs so that one instant is a few seconds on two busy cores.
const std::vector<std::string> kSessionFlags = {"--voxel-mm", "40", "--slab-planes", "10"};

std::string Join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += " " + x;
  return s;
}

// Every output file under `dir` (not the journal, the blob store or the report,
// whose timings differ), relative path -> bytes.
std::map<std::string, std::string> Outputs(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    const std::string rel = fs::relative(e.path(), dir).string();
    if (rel.rfind(".blobs", 0) == 0 || rel.rfind("journal.log", 0) == 0 || rel == "report.json") {
      continue;
    }
    files[rel] = io::ReadFileBytes(e.path());
  }
  return files;
}

void ExpectSameOutputs(const fs::path& reference, const fs::path& out) {
  const auto a = Outputs(reference), b = Outputs(out);
  ASSERT_EQ(a.size(), b.size()) << out;
  for (const auto& [rel, bytes] : a) {
    auto it = b.find(rel);
    ASSERT_NE(it, b.end()) << rel << " missing in " << out;
    EXPECT_TRUE(it->second == bytes) << rel << " differs in " << out;
  }
}

class Cluster : public ::testing::Test {
 protected:
  static fs::path root_, take_, reference_;
  static std::vector<std::string> instants_;

  static void SetUpTestSuite() {
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
    fs::remove_all(root_, ec);
  }

  // A master on loopback with fast heartbeats; endpoints read back from its file.
  struct Master {
    std::unique_ptr<ChildProcess> process;
    std::string workers, control, events;
  };
  Master StartMaster(const std::string& name, std::vector<std::string> extra = {}) {
    Master m;
    const fs::path file = root_ / (name + ".endpoints");
    fs::remove(file);
    std::vector<std::string> args = {"--bind",           "tcp://127.0.0.1:*",
                                     "--control",        "tcp://127.0.0.1:*",
                                     "--events",         "tcp://127.0.0.1:*",
                                     "--heartbeat-ms",   "200",
                                     "--liveness",       "3",
                                     "--endpoints-file", file.string()};
    args.insert(args.end(), extra.begin(), extra.end());
    m.process =
        std::make_unique<ChildProcess>("dome-master", args, (root_ / (name + ".log")).string());
    for (int i = 0; i < 500 && !fs::exists(file); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    std::istringstream in(io::ReadFileBytes(file));
    in >> m.workers >> m.control >> m.events;
    return m;
  }
  std::unique_ptr<ChildProcess> StartWorker(const Master& m, const std::string& name) {
    return std::make_unique<ChildProcess>(
        "dome-worker",
        std::vector<std::string>{"--master", m.workers, "--threads", "1", "--cache-mb", "256",
                                 "--heartbeat-ms", "200", "--liveness", "3", "--name", name},
        (root_ / (name + ".log")).string());
  }

  runtime::Session MakeSession(const fs::path& out) {
    runtime::Session s;
    s.set_take(take_.string());
    s.set_out(out.string());
    s.mutable_volume()->set_voxel_size_mm(40);
    s.set_slab_planes(10);
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
  static int Done(const runtime::SessionStatus& st, int instant, const std::string& stage) {
    for (const auto& s : st.instants(instant).stages()) {
      if (s.stage() == stage) return s.done();
    }
    return -1;
  }

  zmq::context_t context_;
};
fs::path Cluster::root_, Cluster::take_, Cluster::reference_;
std::vector<std::string> Cluster::instants_;

TEST_F(Cluster, EmbeddedRunMatchesOfflineStereoAndFusion) {
  ASSERT_EQ(instants_.size(), 2u);
  const std::string instant = instants_[1];
  // Stereo: `dome stereo` on one camera writes the same depth, reliability and preview.
  const fs::path offline = root_ / "offline";
  const auto st = RunDomeBinary("stereo " + take_.string() + " --camera c00 --instant " + instant +
                                " --threads 1 --out " + offline.string());
  ASSERT_EQ(st.exit_code, 0) << st.output;
  for (const char* sub : {"depth", "reliability", "preview"}) {
    const std::string ext = std::string(sub) == "preview" ? ".png" : ".tiff";
    EXPECT_TRUE(io::ReadFileBytes(offline / instant / sub / ("c00" + ext)) ==
                io::ReadFileBytes(reference_ / instant / sub / ("c00" + ext)))
        << sub;
  }
  // Fusion + marching cubes: `dome fuse` over the runtime's depth maps gives the same mesh.
  const fs::path depth = root_ / "depth_in";
  fs::create_directories(depth / instant);
  for (const auto& e : fs::directory_iterator(reference_ / instant / "depth")) {
    fs::copy_file(e.path(), depth / instant / e.path().filename());
  }
  const auto fu = RunDomeBinary("fuse " + take_.string() + " --instant " + instant +
                                " --depth-dir " + depth.string() +
                                " --voxel-mm 40 --threads 1 --out " + (root_ / "fused").string());
  ASSERT_EQ(fu.exit_code, 0) << fu.output;
  const std::string mesh = io::ReadFileBytes(reference_ / instant / "mesh.ply");
  EXPECT_TRUE(io::ReadFileBytes(root_ / "fused" / instant / "mesh.ply") == mesh);
  // Decimation and vertex colours too.
  EXPECT_TRUE(io::ReadFileBytes(root_ / "fused" / instant / "mesh_decimated.ply") ==
              io::ReadFileBytes(reference_ / instant / "mesh_decimated.ply"));
  const io::Mesh m = io::ParsePly(mesh, "mesh.ply");
  EXPECT_GT(m.faces.size(), 1000u);
  const io::Mesh d = io::ReadPly(reference_ / instant / "mesh_decimated.ply");
  EXPECT_LT(d.faces.size(), m.faces.size());
  EXPECT_EQ(d.colors.size(), d.vertices.size());
  for (const char* f : {"textured.obj", "textured.mtl", "textured.png"}) {
    EXPECT_GT(fs::file_size(reference_ / instant / f), 0u) << f;
  }
  // The same textured mesh as one GLB: its header names the container and its length.
  const std::string glb = io::ReadFileBytes(reference_ / instant / "textured.glb");
  ASSERT_GE(glb.size(), 12u);
  EXPECT_EQ(glb.substr(0, 4), "glTF");
  uint32_t glb_length = 0;
  std::memcpy(&glb_length, glb.data() + 8, 4);
  EXPECT_EQ(glb_length, glb.size());
  const std::string report = io::ReadFileBytes(reference_ / "report.json");
  for (const char* key : {"\"stereo\": {\"jobs\": 12", "\"fusion\": {\"jobs\": 30", "\"surface\"",
                          "\"decimate\"", "\"texture\"", "\"seconds_per_instant\""}) {
    EXPECT_NE(report.find(key), std::string::npos) << key << " in " << report;
  }
}

TEST_F(Cluster, MasterAndThreeWorkerProcessesMatchTheEmbeddedRun) {
  Master m = StartMaster("master3");
  std::vector<std::unique_ptr<ChildProcess>> workers;
  for (int w = 0; w < 3; ++w) workers.push_back(StartWorker(m, "w" + std::to_string(w)));
  const fs::path out = root_ / "three";
  const auto run = RunDomeBinary("run " + take_.string() + " --out " + out.string() + " --master " +
                                 m.control + " --events " + m.events + Join(kSessionFlags));
  ASSERT_EQ(run.exit_code, 0) << run.output << m.process->Log();
  EXPECT_NE(run.output.find("fusion"), std::string::npos) << run.output;  // live progress
  ExpectSameOutputs(reference_, out);
  // Every worker took part (the jobs were spread, not run by one).
  const std::string log = m.process->Log();
  for (int w = 0; w < 3; ++w)
    EXPECT_NE(log.find("worker w" + std::to_string(w) + " joined"), std::string::npos);
  // `dome list` and `dome status` answer from the same master.
  const auto list = RunDomeBinary("list --master " + m.control);
  EXPECT_NE(list.output.find("done"), std::string::npos) << list.output;
}

TEST_F(Cluster, WorkersKilledDuringStereoAndFusionAreRequeued) {
  Master m = StartMaster("master_kill");
  auto w1 = StartWorker(m, "k1");
  const fs::path out = root_ / "killed";
  runtime::Session s = MakeSession(out);
  const std::string id = Submit(m, s);
  // One worker: once a depth map is in, it is on the next stereo job. Kill it.
  ASSERT_TRUE(WaitFor(m, id, [](const auto& st) { return Done(st, 0, "stereo") >= 1; }));
  ASSERT_LT(Done(Status(m, id), 0, "stereo"), 6);
  w1->Kill();
  auto w2 = StartWorker(m, "k2");
  // Again one worker, now busy with instant 0's slabs.
  ASSERT_TRUE(WaitFor(m, id, [](const auto& st) { return Done(st, 0, "fusion") >= 1; }));
  ASSERT_LT(Done(Status(m, id), 0, "fusion"), 15);
  w2->Kill();
  auto w3 = StartWorker(m, "k3");
  auto w4 = StartWorker(m, "k4");
  WaitFor(
      m, id, [](const auto&) { return false; }, 120);
  const auto final = Status(m, id);
  ASSERT_EQ(final.state(), "done") << final.error() << m.process->Log();
  ExpectSameOutputs(reference_, out);
  const std::string log = m.process->Log();
  EXPECT_NE(log.find("worker k1 "), std::string::npos);
  EXPECT_NE(log.find("re-queued job " + id + "/" + instants_[0] + "/stereo/"), std::string::npos)
      << log;
  EXPECT_NE(log.find("re-queued job " + id + "/" + instants_[0] + "/fusion/"), std::string::npos)
      << log;
}

TEST_F(Cluster, GarbageOnEverySocketIsRefusedAndASessionStillCompletes) {
  Master m = StartMaster("master_garbage", {"--max-message-bytes", "4000000"});
  std::mt19937 rng(7);
  auto random_bytes = [&](size_t n) {
    std::string s(n, '\0');
    for (auto& c : s) c = char(rng());
    return s;
  };
  zmq::socket_t dealer(context_, zmq::socket_type::dealer);
  dealer.set(zmq::sockopt::linger, 0);
  dealer.connect(m.workers);
  zmq::socket_t control(context_, zmq::socket_type::dealer);
  control.set(zmq::sockopt::linger, 0);
  control.connect(m.control);
  // Thousands of random messages on both sockets, some multipart.
  for (int i = 0; i < 2000; ++i) {
    const std::string bytes = random_bytes(1 + rng() % 200);
    dealer.send(zmq::buffer(bytes), i % 50 == 0 ? zmq::send_flags::sndmore : zmq::send_flags::none);
    if (i % 50 == 0) dealer.send(zmq::buffer(bytes), zmq::send_flags::none);
    control.send(zmq::str_buffer(""), zmq::send_flags::sndmore);
    control.send(zmq::buffer(bytes), zmq::send_flags::none);
  }
  // A truncated valid message, another protocol version, an oversized message, and a
  // result for a job that does not exist.
  runtime::Envelope hello;
  hello.mutable_hello()->set_threads(1);
  const std::string valid = net::EncodeEnvelope(hello);
  dealer.send(zmq::buffer(valid.substr(0, valid.size() - 1)), zmq::send_flags::none);
  runtime::Envelope wrong = hello;
  wrong.set_version(net::kProtocolVersion + 1);
  std::string wrong_bytes;
  wrong.SerializeToString(&wrong_bytes);
  dealer.send(zmq::buffer(wrong_bytes), zmq::send_flags::none);
  dealer.send(zmq::buffer(std::string(4500000, 'x')), zmq::send_flags::none);
  runtime::Envelope result;
  result.mutable_result()->set_job_id("nosuchsession/00-00-00-00/stereo/c00");
  result.mutable_result()->set_ok(true);
  dealer.send(zmq::buffer(net::EncodeEnvelope(result)), zmq::send_flags::none);
  // The peer hears why: a Refusal naming the version for the wrong-version message.
  bool saw_version_refusal = false;
  for (int i = 0; i < 5000 && !saw_version_refusal; ++i) {
    zmq::pollitem_t items[] = {{dealer.handle(), 0, ZMQ_POLLIN, 0}};
    zmq::poll(items, 1, std::chrono::milliseconds(20));
    zmq::message_t msg;
    while (dealer.recv(msg, zmq::recv_flags::dontwait)) {
      runtime::Envelope env;
      if (env.ParseFromArray(msg.data(), int(msg.size())) && env.has_refusal() &&
          env.refusal().reason().find("protocol version " +
                                      std::to_string(net::kProtocolVersion + 1)) !=
              std::string::npos) {
        saw_version_refusal = true;
      }
    }
  }
  EXPECT_TRUE(saw_version_refusal);
  // The master still serves: a session on one instant completes with the same bytes.
  auto w = StartWorker(m, "g1");
  const fs::path out = root_ / "after_garbage";
  runtime::Session s = MakeSession(out);
  s.add_instants(instants_[0]);
  const std::string id = Submit(m, s);
  WaitFor(
      m, id, [](const auto&) { return false; }, 120);
  ASSERT_EQ(Status(m, id).state(), "done") << m.process->Log();
  for (const char* f : {"mesh.ply", "mesh_decimated.ply", "textured.obj", "textured.png"}) {
    const std::string rel = instants_[0] + "/" + f;
    EXPECT_TRUE(io::ReadFileBytes(out / rel) == io::ReadFileBytes(reference_ / rel)) << rel;
  }
  const std::string log = m.process->Log();
  for (const char* what :
       {"not a dome runtime envelope", "over the cap of 4000000", "unknown job id 'nosuchsession/",
        "frames on the worker socket", "refused on the control socket"}) {
    EXPECT_NE(log.find(what), std::string::npos) << what;
  }
  EXPECT_NE(log.find("speaks protocol version " + std::to_string(net::kProtocolVersion + 1)),
            std::string::npos);
  EXPECT_EQ(m.process->Stop(), 0);
}

}  // namespace
}  // namespace dome
