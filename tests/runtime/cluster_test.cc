// The runtime end to end with real processes on loopback: dome-master, dome-worker
// processes and the dome client on the small synthetic take. Every run must produce
// the same bytes as the embedded `dome run`, which itself must match the offline
// `dome stereo` and `dome fuse` on the same inputs.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>
#include <zmq.hpp>

#include "cli/client.h"
#include "io/file_util.h"
#include "io/ply.h"
#include "net/content_hash.h"
#include "net/security.h"
#include "net/wire.h"
#include "runtime/cluster_fixture.h"
#include "runtime/process.h"
#include "schema/json.h"
#include "testing/run_command.h"

namespace dome {
namespace {
namespace fs = std::filesystem;
using testing::ChildProcess;
using testing::ExpectSameOutputs;
using testing::Join;
using testing::kSessionFlags;
using testing::RunDomeBinary;

using Cluster = testing::ClusterFixture;

// A control socket that takes requests and never answers: the client gives up after
// --timeout-s, naming the endpoint.
TEST(ClientTimeout, ControlCommandsGiveUpAfterTimeoutS) {
  zmq::context_t context;
  zmq::socket_t silent(context, zmq::socket_type::router);
  silent.bind("tcp://127.0.0.1:*");
  const std::string endpoint = net::BoundEndpoint(silent);
  for (const std::string command : {"status", "list", "cancel abc", "submit /nonexistent"}) {
    const auto start = std::chrono::steady_clock::now();
    const auto r = RunDomeBinary(command + " --master " + endpoint + " --insecure --timeout-s 0.3" +
                                 (command.rfind("submit", 0) == 0 ? " --out /tmp/unused" : ""));
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_NE(r.exit_code, 0) << command << ": " << r.output;
    EXPECT_NE(r.output.find(endpoint), std::string::npos) << command << ": " << r.output;
    EXPECT_NE(r.output.find("no answer within 300 ms"), std::string::npos)
        << command << ": " << r.output;
    EXPECT_LT(seconds, 8.0) << command << " waited for the default 10 s";
  }
  const auto bad = RunDomeBinary("status --master " + endpoint + " --insecure --timeout-s 0");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.output.find("--timeout-s"), std::string::npos) << bad.output;
}

TEST_F(Cluster, EmbeddedRunMatchesOfflineStereoAndFusion) {
  ASSERT_EQ(instants_.size(), 2u);
  // The first instant: the session has no masks (kSessionFlags), so its fusion is
  // time-aware, and the second instant's adds the first's evidence, which `dome fuse`
  // of that instant alone does not (pipeline/derive.cc).
  const std::string instant = instants_[0];
  // The options the run derived (REFERENCE/session.json) for the offline commands.
  const runtime::Session session = MakeSession(root_ / "unused");
  const fs::path options = root_ / "stereo_options.json";
  io::WriteFileAtomically(options, schema::PrintJson(session.stereo()));
  // Stereo: `dome stereo` on one camera writes the same depth, reliability and preview.
  const fs::path offline = root_ / "offline";
  const auto st =
      RunDomeBinary("stereo " + take_.string() + " --camera c00 --instant " + instant +
                    " --options " + options.string() + " --threads 1 --out " + offline.string());
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
  const auto& v = session.volume();
  const auto fu = RunDomeBinary(
      "fuse " + take_.string() + " --instant " + instant + " --depth-dir " + depth.string() +
      fmt::format(" --voxel-mm {:.17g} --origin ", v.voxel_size_mm()) +
      fmt::format("{:.17g} {:.17g} {:.17g}", v.origin_mm(0), v.origin_mm(1), v.origin_mm(2)) +
      fmt::format(" --dims {} {} {}", v.dims(0), v.dims(1), v.dims(2)) +
      fmt::format(" --truncation-mm {:.17g} --clamp-mm {:.17g}", session.fusion().truncation_mm(),
                  session.fusion().front_clamp_mm()) +
      " --threads 1 --out " + (root_ / "fused").string());
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
  // The master keeps each output file once on disk: the blob a restarted master would
  // find it by (OUT/.blobs/<sha256>) is the same file under a second name.
  for (const char* f : {"mesh.ply", "mesh_decimated.ply", "textured.obj", "textured.glb"}) {
    const fs::path file = reference_ / instant / f;
    const fs::path blob = reference_ / ".blobs" / net::Sha256Hex(io::ReadFileBytes(file));
    ASSERT_TRUE(fs::exists(blob)) << f;
    EXPECT_TRUE(fs::equivalent(file, blob)) << f;
  }
  // The same textured mesh as one GLB: its header names the container and its length.
  const std::string glb = io::ReadFileBytes(reference_ / instant / "textured.glb");
  ASSERT_GE(glb.size(), 12u);
  EXPECT_EQ(glb.substr(0, 4), "glTF");
  uint32_t glb_length = 0;
  std::memcpy(&glb_length, glb.data() + 8, 4);
  EXPECT_EQ(glb_length, glb.size());
  const auto report = nlohmann::json::parse(io::ReadFileBytes(reference_ / "report.json"));
  EXPECT_EQ(report["stages"]["stereo"]["jobs"], 12) << report;
  // Slabs of 5 planes over the derived volume's z extent, for each of the 2 instants.
  EXPECT_EQ(report["stages"]["fusion"]["jobs"], 2 * ((v.dims(2) + 4) / 5)) << report;
  EXPECT_EQ(report["volume"]["dims"][2], v.dims(2)) << report;
  EXPECT_FALSE(report["derived"].empty()) << report;
  for (const char* stage : {"surface", "decimate", "texture"}) {
    EXPECT_EQ(report["stages"][stage]["jobs"], 2) << stage << " in " << report;
  }
  EXPECT_FALSE(report["stages"].contains("noop"));  // a stage with no jobs is not listed
  EXPECT_GT(report["seconds_per_instant"].get<double>(), 0.0);
  // Clean output: each instant's decimation.json, in the report per instant and summed.
  int64_t specks = 0, speck_triangles = 0, surface_triangles = 0;
  for (const auto& entry : report["per_instant"]) {
    const auto file = nlohmann::json::parse(io::ReadFileBytes(
        reference_ / entry["instant"].get<std::string>() / "decimation.json"));
    EXPECT_EQ(entry["decimation"], file) << report;
    specks += file["specks_removed"].get<int64_t>();
    speck_triangles += file["speck_triangles"].get<int64_t>();
    surface_triangles += file["triangles_in"].get<int64_t>();
  }
  EXPECT_EQ(report["clean"]["instants"], 2) << report;
  EXPECT_EQ(report["clean"]["specks_removed"], specks) << report;
  EXPECT_EQ(report["clean"]["speck_triangles"], speck_triangles) << report;
  EXPECT_NEAR(report["clean"]["speck_triangle_share"].get<double>(),
              double(speck_triangles) / double(surface_triangles), 1e-12);
  // The instant's file counts the triangles of its mesh.ply.
  const auto first = nlohmann::json::parse(io::ReadFileBytes(reference_ / instant / "decimation.json"));
  EXPECT_EQ(first["triangles_in"], int64_t(m.faces.size()));
  EXPECT_EQ(first["triangles_out"], int64_t(d.faces.size()));
}

// As deployed: CURVE on every socket, the workers' and the client's keys allowed; three
// writer threads store the results as they come (the embedded run has one).
TEST_F(Cluster, MasterAndThreeWorkerProcessesMatchTheEmbeddedRun) {
  const fs::path keys = root_ / "keys";
  fs::create_directories(keys);
  net::WriteKeyPair((keys / "master").string(), net::GenerateKeyPair());
  net::WriteKeyPair((keys / "worker").string(), net::GenerateKeyPair(), "worker");
  net::WriteKeyPair((keys / "client").string(), net::GenerateKeyPair(), "client");
  io::WriteFileAtomically(keys / "allowed_keys", io::ReadFileBytes(keys / "worker.pub") +
                                                     io::ReadFileBytes(keys / "client.pub"));
  const std::string client_keys = " --master-key " + (keys / "master.pub").string() + " --key " +
                                  (keys / "client.key").string();
  Master m = StartMaster("master3", {"--keys", keys.string(), "--writer-threads", "3"});
  std::vector<std::unique_ptr<ChildProcess>> workers;
  for (int w = 0; w < 3; ++w) {
    workers.push_back(StartWorker(
        m, "w" + std::to_string(w),
        {"--master-key", (keys / "master.pub").string(), "--key", (keys / "worker.key").string()}));
  }
  const fs::path out = root_ / "three";
  const auto run =
      RunDomeBinary("run " + take_.string() + " --out " + out.string() + " --master " + m.control +
                    " --events " + m.events + client_keys + Join(kSessionFlags));
  ASSERT_EQ(run.exit_code, 0) << run.output << m.process->Log();
  EXPECT_NE(run.output.find("fusion"), std::string::npos) << run.output;  // live progress
  ExpectSameOutputs(reference_, out);
  // Every worker took part (the jobs were spread, not run by one).
  const std::string log = m.process->Log();
  for (int w = 0; w < 3; ++w)
    EXPECT_NE(log.find("worker w" + std::to_string(w) + " joined"), std::string::npos);
  // The scheduling figures of report.json: three workers run at most one job each at a
  // time, so their job seconds fit in three times the session's; the loop's busy
  // share is a fraction, its longest turn within the session.
  const std::string report = io::ReadFileBytes(out / "report.json");
  auto number = [&](const std::string& key) {
    const auto p = report.find("\"" + key + "\": ");
    return p == std::string::npos ? -1.0 : std::stod(report.substr(p + key.size() + 4));
  };
  const double seconds = number("seconds");
  ASSERT_GT(seconds, 0) << report;
  EXPECT_GT(number("worker_job_seconds"), 0) << report;
  EXPECT_LE(number("worker_job_seconds"), 3 * seconds) << report;
  EXPECT_GT(number("busy_fraction"), 0) << report;
  EXPECT_LE(number("busy_fraction"), 1) << report;
  EXPECT_GE(number("longest_turn_s"), 0) << report;
  EXPECT_LE(number("longest_turn_s"), seconds) << report;
  // `dome list` and `dome status` answer from the same master.
  const auto list = RunDomeBinary("list --master " + m.control + client_keys);
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
  // Logs from network peers are throttled per peer and cause: 2,000 bad messages on each
  // socket make a few lines, not a line each.
  for (const std::string what : {"refused on the control socket", "refused on the worker socket"}) {
    size_t lines = 0;
    for (size_t p = log.find(what); p != std::string::npos; p = log.find(what, p + 1)) ++lines;
    EXPECT_GE(lines, 1u) << what;
    EXPECT_LE(lines, 20u) << what << "\n" << log;
  }
  EXPECT_EQ(m.process->Stop(), 0);
}

}  // namespace
}  // namespace dome
