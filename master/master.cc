#include "master/master.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <thread>
#include <vector>

#include "core/error.h"
#include "core/json.h"
#include "core/memory.h"
#include "core/wake_pipe.h"
#include "io/file_util.h"
#include "master/blob_store.h"
#include "master/capture_host.h"
#include "master/graph.h"
#include "master/journal.h"
#include "master/offload.h"
#include "net/content_hash.h"
#include "net/events.h"
#include "net/log_throttle.h"
#include "net/security.h"
#include "pipeline/session.h"
#include "pipeline/stages.h"
#include "schema/json.h"

namespace dome::scheduler {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using pipeline::StageDescriptor;

void MasterOptions::Check() const {
  core::Require(heartbeat_interval_ms > 0, "heartbeat_interval_ms",
                "must be positive, got " + std::to_string(heartbeat_interval_ms));
  core::Require(heartbeat_liveness > 0, "heartbeat_liveness",
                "must be positive, got " + std::to_string(heartbeat_liveness));
  core::Require(max_job_losses > 0, "max_job_losses", "must be positive");
  core::Require(
      std::isfinite(job_timeout_s) && job_timeout_s >= 0, "job_timeout_s",
      "must be 0 (derived) or a positive number of seconds, got " + std::to_string(job_timeout_s));
  core::Require(std::isfinite(job_timeout_min_s) && job_timeout_min_s > 0, "job_timeout_min_s",
                "must be a positive number of seconds, got " + std::to_string(job_timeout_min_s));
  core::Require(std::isfinite(job_timeout_first_s_per_mib) && job_timeout_first_s_per_mib >= 0,
                "job_timeout_first_s_per_mib",
                "must not be negative, got " + std::to_string(job_timeout_first_s_per_mib));
  core::Require(std::isfinite(job_timeout_factor) && job_timeout_factor >= 1, "job_timeout_factor",
                "must be at least 1, got " + std::to_string(job_timeout_factor));
  core::Require(std::isfinite(release_memory_s) && release_memory_s >= 0, "release_memory_s",
                "must be 0 (never) or a positive number of seconds");
  core::Require(max_job_mb >= 0, "max_job_mb",
                "must be 0 (this machine's memory) or a positive MiB count, got " +
                    std::to_string(max_job_mb));
  core::Require(jobs_ahead >= 0 && jobs_ahead <= 16, "jobs_ahead",
                "must be in 0..16, got " + std::to_string(jobs_ahead));
  core::Require(
      writer_threads >= 0 && writer_threads <= 256, "writer_threads",
      "must be in 0..256 (0 = half the hardware threads), got " + std::to_string(writer_threads));
  core::Require(stages != nullptr && !stages->stages.empty(), "stages", "names no stage");
  socket.Check();
}

namespace {

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

// The vertex count in the header of a PLY file (its "element vertex N" line, within
// the first 4 KiB: the header the surface stage writes is a few hundred bytes); -1
// when the file is missing or has no such line. Only the header is read: the report
// counts the empty surfaces of every instant, resumed ones included, without reading
// their meshes.
int64_t PlyVertexCount(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return -1;
  std::string head(4096, '\0');
  in.read(head.data(), std::streamsize(head.size()));
  head.resize(size_t(in.gcount()));
  const std::string key = "\nelement vertex ";
  const size_t at = head.find(key);
  const size_t end = head.find("end_header");
  if (at == std::string::npos || (end != std::string::npos && at > end)) return -1;
  try {
    return std::stoll(head.substr(at + key.size(), 20));
  } catch (const std::exception&) {
    return -1;
  }
}

// What a refusal is about, for throttling its log lines: the message without its
// quoted parts and numbers ("message of 4500000 bytes ...", "message of 73 bytes ..."
// and "unknown job id 'x'" each count as one cause however they vary: random bytes of
// a hundred lengths made a hundred lines), except a protocol version's ("protocol
// version 4" stays apart from "protocol version 3091264").
std::string Cause(const std::string& message) {
  std::string cause;
  bool quoted = false;
  for (size_t i = 0; i < message.size();) {
    const char c = message[i];
    if (c == '\'') quoted = !quoted;
    size_t digits = 0;
    while (i + digits < message.size() && std::isdigit((unsigned char)message[i + digits])) {
      ++digits;
    }
    const bool version = digits > 0 && i >= 8 && message.compare(i - 8, 8, "version ") == 0;
    if ((digits > 0 && !version) || (quoted && c != '\'')) {
      i += std::max<size_t>(digits, 1);
      continue;
    }
    cause.append(message, i, std::max<size_t>(digits, 1));
    i += std::max<size_t>(digits, 1);
  }
  return cause;
}

std::string NewSessionId() {
  static std::mt19937_64 rng(std::random_device{}());
  char buf[17];
  std::snprintf(buf, sizeof buf, "%08llx", (unsigned long long)(rng() & 0xffffffffULL));
  return buf;
}

// A session's state; on the wire as its name (runtime.SessionStatus.state).
enum class SessionState { kRunning, kDone, kFailed, kCancelled };

const char* StateName(SessionState state) {
  static constexpr const char* kNames[] = {"running", "done", "failed", "cancelled"};
  return kNames[static_cast<int>(state)];
}

struct WorkerRec {
  std::string id;    // routing id
  std::string name;  // from Hello
  int threads = 1;
  int64_t cache_mb = 0;
  Clock::time_point expiry;
  // Wire ids of the jobs sent and not yet answered, oldest (the running one) first;
  // empty when idle. More than one when jobs were sent ahead (MasterOptions).
  std::deque<std::string> jobs;
  // Since when jobs.front() has been the job it runs (its time-out counts from here: a
  // job sent ahead waits for the one before it).
  Clock::time_point front_since = Clock::now();
  // Jobs it was told to drop after they timed out while it ran them: it cannot stop a
  // running job, so it gets no more work while others can take it (until the result
  // of one of them comes, late).
  std::set<std::string> stuck;
  void Add(const std::string& job_id) {
    if (jobs.empty()) front_since = Clock::now();
    jobs.push_back(job_id);
  }
  bool Forget(const std::string& job_id) {
    auto it = std::find(jobs.begin(), jobs.end(), job_id);
    if (it == jobs.end()) return false;
    if (it == jobs.begin()) front_since = Clock::now();
    jobs.erase(it);
    return true;
  }
};

struct StageStats {
  double job_seconds = 0;         // summed over jobs
  double slowest_s_per_mib = -1;  // worker jobs: the most seconds per input MiB; -1: none yet
  double first_start = -1, last_done = -1;               // seconds since the session started
  int64_t bytes_to_workers = 0, bytes_from_workers = 0;  // blobs served, outputs received
};

struct InstantStats {
  double first_start = -1, done = -1;
  std::map<std::string, double> job_seconds;  // per stage, summed over the instant's jobs
};

// A session's outputs in the master's blob store, kept under OUT/.blobs.
class SessionBlobs : public pipeline::BlobAccess {
 public:
  SessionBlobs(BlobStore* store, fs::path dir) : store_(store), dir_(std::move(dir)) {}
  std::optional<std::string> Read(const std::string& sha256) const override {
    return store_->Read(sha256, nullptr);
  }
  runtime::BlobRef Keep(const std::string& bytes, const std::string& name) override {
    return store_->AddBytes(dir_, bytes, name);
  }
  runtime::BlobRef KeepWritten(const std::string& bytes, const std::string& name,
                               const fs::path& written) override {
    return store_->AddBytes(dir_, bytes, name, written);
  }

 private:
  BlobStore* store_;
  fs::path dir_;
};

struct SessionRec {
  std::string id;
  pipeline::SessionPlan plan;
  std::vector<std::string> input_digests;  // per instant: pipeline::InstantInputsDigests
  std::set<std::string> input_shas;        // the take files it reads (rig and frames)
  std::unique_ptr<JobGraph> graph;
  std::unique_ptr<Journal> journal;
  std::unique_ptr<SessionBlobs> blobs;
  std::map<int, std::vector<runtime::BlobRef>> outputs;  // node -> output blobs (by name order)
  std::map<int, std::string> running_on;                 // node -> worker id
  std::map<int, int> losses;           // node -> times lost (worker lost, timed out, bad result)
  std::map<int, int64_t> input_bytes;  // node -> its inputs' bytes, as sent
  std::map<int, double> dispatched_at;
  SessionState state = SessionState::kRunning;
  std::string error;
  Clock::time_point start = Clock::now();
  double finished_s = -1;
  std::vector<StageStats> stage_stats;  // by stage
  std::vector<InstantStats> instant_stats;
  int64_t bytes_to_workers = 0, bytes_from_workers = 0;
  int requeued = 0, duplicates = 0, resumed = 0;
  std::map<std::string, int> jobs_by_worker;  // worker name -> results accepted from it
  // (instant, stage) -> the run of a master stage, fed its input's outputs as they finish.
  std::map<std::pair<int, int>, std::unique_ptr<pipeline::MasterStageRun>> master_runs;
  // The master loop while this session ran: its busy seconds when the session started
  // (the loop's running total), and its longest turn since.
  double loop_busy_at_start = 0, loop_longest_turn_s = 0;

  bool running() const { return state == SessionState::kRunning; }
  fs::path out() const { return plan.spec.out(); }
  fs::path instant_dir(int instant) const { return out() / plan.instants[instant]; }
  double Now() const { return Seconds(Clock::now() - start); }
};

// A journal is fsync'd at most this often (journal.h): one fsync costs milliseconds on
// the loop, and records lost to a power cut only redo their (idempotent) jobs.
constexpr auto kJournalSyncInterval = std::chrono::milliseconds(50);

// The longest message the events socket takes (Bind): the handshake and a subscriber's
// Heartbeat or Disconnect (net/events.h), in plaintext and in CURVE's framing.
constexpr int kMaxSubscriptionBytes = 64;
constexpr int kMaxCurveSubscriptionBytes = 512;

}  // namespace

struct Master::Impl {
  zmq::context_t* context;
  MasterOptions options;
  const pipeline::StageSet& stages;
  MasterEndpoints endpoints;
  zmq::socket_t workers_socket, control_socket, events_socket;
  std::unique_ptr<net::EventSubscribers> subscribers;  // of events_socket
  std::unique_ptr<net::HandshakeLog> handshake_log;  // after the sockets: destroyed first
  std::map<std::string, WorkerRec> workers;
  // Woken by a master stage's run as it ends (before the sessions that hold the runs:
  // it outlives their threads); polled by Run beside the sockets.
  core::WakePipe stage_done{"master"};
  std::map<std::string, std::unique_ptr<SessionRec>> sessions;
  std::vector<std::string> session_order;
  std::unique_ptr<ingest::FrameIngest> capture_ingest;  // with capture_endpoint
  BlobStore blobs;
  Clock::time_point next_heartbeat = Clock::now();
  Clock::time_point next_journal_sync = Clock::now();
  double loop_busy_s = 0;                     // the loop's time outside poll, summed over its turns
  Clock::time_point now_trim = Clock::now();  // next ReleaseFreedMemory
  net::LogThrottle peer_log;                  // refusals of peers' messages, per peer
  // Last member: destroyed first, so its threads stop before what their work touches.
  Offload offload;

  Impl(zmq::context_t* ctx, const MasterOptions& o)
      : context(ctx),
        options(o),
        stages(*o.stages),
        workers_socket(*ctx, zmq::socket_type::router),
        control_socket(*ctx, zmq::socket_type::router),
        events_socket(*ctx, zmq::socket_type::router),
        offload(WriterThreads(o)) {
    Bind(&workers_socket, options.worker_endpoint, "--bind", net::kRoleWorker, &endpoints.workers);
    Bind(&control_socket, options.control_endpoint, "--control", net::kRoleClient,
         &endpoints.control);
    Bind(&events_socket, options.events_endpoint, "--events", net::kRoleClient, &endpoints.events);
    subscribers = std::make_unique<net::EventSubscribers>(&events_socket);
    handshake_log = std::make_unique<net::HandshakeLog>(
        ctx,
        std::vector<std::pair<zmq::socket_t*, std::string>>{
            {&workers_socket, "worker"}, {&control_socket, "control"}, {&events_socket, "events"}});
    if (!options.capture_endpoint.empty()) {
      net::SocketOptions capture = options.socket;
      capture.zap_domain = net::kRoleCapture;
      capture_ingest =
          HostCaptureIngest(context, options.capture_endpoint, options.capture_take, capture,
                            [this](const runtime::StatusEvent& ev) {
                              runtime::Envelope env;
                              *env.mutable_status() = ev;
                              subscribers->Publish(env);
                            });
      endpoints.capture = capture_ingest->endpoint();
    }
    LoadState();
  }

  static int WriterThreads(const MasterOptions& o) {
    o.Check();
    if (o.writer_threads > 0) return o.writer_threads;
    return std::max(1, int(std::thread::hardware_concurrency()) / 2);
  }

  // The socket's ZAP domain is `role`: with keys, only peers allowed that role get in
  // (net/security.h).
  void Bind(zmq::socket_t* s, const std::string& endpoint, const std::string& flag,
            const char* role, std::string* bound) {
    net::SocketOptions socket = options.socket;
    socket.zap_domain = role;
    net::ConfigureSocket(s, socket);
    if (s == &events_socket) {
      // A subscriber sends only Heartbeats and a Disconnect (net/events.h: a few bytes
      // each), so the socket drops a peer that sends anything long before it is read.
      // The cap must pass the handshake's READY command (about 40 bytes: the socket type
      // and identity); CURVE frames its handshake and messages in commands of a few
      // hundred bytes, so there it is 512 (from peers the allow-list lets in as
      // clients). Set before bind: a listener copies the options its connections get.
      s->set(zmq::sockopt::maxmsgsize,
             int64_t{socket.curve_server() ? kMaxCurveSubscriptionBytes : kMaxSubscriptionBytes});
    }
    if (s == &workers_socket) s->set(zmq::sockopt::router_mandatory, 1);
    try {
      s->bind(endpoint);
    } catch (const zmq::error_t& e) {
      throw core::InputError(flag + " " + endpoint, std::string("cannot bind: ") + e.what());
    }
    *bound = net::BoundEndpoint(*s);
  }

  const StageDescriptor& StageOf(const SessionRec& s, int node) const {
    return stages.stages[s.graph->node(node).stage];
  }

  // ---- sending ----------------------------------------------------------------------

  void SendToWorker(const std::string& id, const runtime::Envelope& env) {
    const std::string bytes = net::EncodeEnvelope(env);
    try {
      if (!net::SendFrames(&workers_socket, {id, bytes})) {
        spdlog::warn("{}: send would block; message dropped", net::PeerName(id));
      }
    } catch (const zmq::error_t& e) {
      // router_mandatory: the peer is gone. Its expiry will re-queue its job.
      spdlog::debug("{}: cannot send ({})", net::PeerName(id), e.what());
    }
  }

  // Sends `env` to peer `id` of a ROUTER socket; REQ peers get the empty delimiter
  // frame they expect.
  static void Reply(zmq::socket_t* s, const std::string& id, bool req,
                    const runtime::Envelope& env) {
    const std::string bytes = net::EncodeEnvelope(env);
    try {
      if (req) {
        net::SendFrames(s, {id, "", bytes});
      } else {
        net::SendFrames(s, {id, bytes});
      }
    } catch (const zmq::error_t&) {
      // The peer is gone; nothing waits for the answer.
    }
  }

  static void Refuse(zmq::socket_t* s, const std::string& id, const std::string& reason, bool req) {
    runtime::Envelope env;
    env.mutable_refusal()->set_reason(reason);
    Reply(s, id, req, env);
  }

  // A status event of `s`; of one stage of one instant when `node` >= 0.
  void Publish(const SessionRec& s, int node, const std::string& message) {
    runtime::Envelope env;
    auto* ev = env.mutable_status();
    ev->set_session_id(s.id);
    ev->set_state(StateName(s.state));
    ev->set_elapsed_s(s.finished_s >= 0 ? s.finished_s : s.Now());
    if (s.graph) {
      ev->set_jobs_done(s.graph->done());
      ev->set_jobs_total(s.graph->size());
      if (node >= 0) {
        const JobNode& n = s.graph->node(node);
        ev->set_instant(s.plan.instants[n.instant]);
        ev->set_stage(stages.stages[n.stage].name);
        const StageCount c = s.graph->Count(n.instant, n.stage);
        ev->set_done(c.done);
        ev->set_total(c.total);
      }
    }
    ev->set_message(message);
    subscribers->Publish(env);
  }

  // ---- sessions -----------------------------------------------------------------------

  // Refuses an output folder outside MasterOptions::out_root, before anything is made.
  void CheckOutRoot(const std::string& out) const {
    if (options.out_root.empty()) return;
    std::error_code ec;
    const fs::path root = fs::weakly_canonical(fs::absolute(options.out_root), ec);
    const fs::path path = fs::weakly_canonical(fs::absolute(out), ec);
    auto [r, p] = std::mismatch(root.begin(), root.end(), path.begin(), path.end());
    // A trailing empty component ("/srv/dome/") matches anything below.
    const bool inside = !ec && (r == root.end() || (std::next(r) == root.end() && r->empty()));
    core::Require(inside, "session: out",
                  "'" + out + "' is outside the master's output root " + root.string() +
                      " (dome-master --out-root); give a folder inside it");
  }

  // ---- sessions kept across restarts (MasterOptions::state_dir) ----------------------

  fs::path StateFile(const std::string& id, const char* ext) const {
    return fs::path(options.state_dir) / "sessions" / (id + ext);
  }

  // Records a session submitted (its spec) or ended (its state and reason); a failure
  // to write is logged: the session itself is not affected.
  void KeepState(const SessionRec& s, bool ended) {
    if (options.state_dir.empty()) return;
    try {
      if (ended) {
        io::WriteFileAtomically(StateFile(s.id, ".end"),
                                std::string(StateName(s.state)) + "\n" + s.error + "\n");
      } else {
        io::WriteFileAtomically(StateFile(s.id, ".json"), schema::PrintJson(s.plan.spec) + "\n");
      }
    } catch (const core::InputError& e) {
      spdlog::error("session {}: cannot keep its state: {}", s.id, e.what());
    }
  }

  // The sessions of an earlier master on the same state folder: those that ended are
  // listed as they ended; the others are submitted again under their ids.
  void LoadState() {
    if (options.state_dir.empty()) return;
    const fs::path dir = fs::path(options.state_dir) / "sessions";
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec)
      throw core::StorageError(dir.string(), "cannot create the state folder: " + ec.message());
    std::vector<std::pair<fs::file_time_type, fs::path>> specs;
    for (const auto& e : fs::directory_iterator(dir)) {
      if (e.path().extension() == ".json") specs.emplace_back(e.last_write_time(ec), e.path());
    }
    std::sort(specs.begin(), specs.end());  // submitted first, listed first
    int resumed = 0;
    for (const auto& [time, path] : specs) {
      const std::string id = path.stem().string();
      runtime::Session spec;
      try {
        schema::ParseJson(io::ReadFileBytes(path), path.string(), "session", &spec);
      } catch (const core::InputError& e) {
        spdlog::error("state: {}; skipped", e.what());
        continue;
      }
      const fs::path end = StateFile(id, ".end");
      if (fs::exists(end, ec)) {
        auto s = std::make_unique<SessionRec>();
        s->id = id;
        s->plan.spec = spec;
        std::istringstream in(io::ReadFileBytes(end));
        std::string state;
        std::getline(in, state);
        std::getline(in, s->error);
        s->state = state == "done"        ? SessionState::kDone
                   : state == "cancelled" ? SessionState::kCancelled
                                          : SessionState::kFailed;
        s->finished_s = 0;
        session_order.push_back(id);
        sessions[id] = std::move(s);
        continue;
      }
      try {
        Submit(spec, id);
        ++resumed;
      } catch (const core::InputError& e) {
        // Listed as failed with the reason (its take gone, say), not dropped unseen.
        auto s = std::make_unique<SessionRec>();
        s->id = id;
        s->plan.spec = spec;
        s->state = SessionState::kFailed;
        s->error = std::string("cannot resume after a master restart: ") + e.what();
        s->finished_s = 0;
        spdlog::error("session {}: {}", id, s->error);
        KeepState(*s, true);
        session_order.push_back(id);
        sessions[id] = std::move(s);
      }
    }
    if (!specs.empty()) {
      spdlog::info("state {}: {} sessions known, {} resumed", options.state_dir, specs.size(),
                   resumed);
    }
  }

  // What a submit reads, hashes and builds: the plan (the take's rig and every frame:
  // seconds for a take of thousands of instants), the job graph and the inputs' digests
  // per instant (0.3 s for the 84,000 jobs of 4,000 instants of the small take here,
  // which on the loop kept it from its workers' heartbeats: a worker whose liveness is
  // 600 ms reconnected under load). Thread-safe and touching nothing of the loop's, so
  // that it runs beside the loop.
  std::unique_ptr<SessionRec> Prepare(const runtime::Session& spec) {
    CheckOutRoot(spec.out());
    auto s = std::make_unique<SessionRec>();
    s->plan = pipeline::PlanSession(spec, [&](const fs::path& path, const std::string& name) {
      return blobs.AddFile(path, name);  // BlobStore is thread-safe
    });
    CheckJobMemory(s->plan);
    s->graph = std::make_unique<JobGraph>(s->plan.instants, GraphStages(stages, s->plan));
    s->stage_stats.resize(stages.stages.size());
    s->instant_stats.resize(s->plan.instants.size());
    s->input_shas.insert(s->plan.rig.sha256());
    s->input_digests = pipeline::InstantInputsDigests(s->plan);
    for (size_t t = 0; t < s->plan.instants.size(); ++t) {
      for (const auto& f :
           s->plan.frames.size() > t ? s->plan.frames[t] : std::vector<runtime::BlobRef>{}) {
        s->input_shas.insert(f.sha256());
      }
    }
    return s;
  }

  // `id_to_resume`: the session's id when resumed from the state folder; "" for a new one.
  std::string Submit(const runtime::Session& spec, const std::string& id_to_resume = "") {
    return Start(spec, Prepare(spec), id_to_resume);
  }

  // A prepared session starts: its folder and journal (resuming what it records).
  std::string Start(const runtime::Session& spec, std::unique_ptr<SessionRec> s,
                    const std::string& id_to_resume = "") {
    s->start = Clock::now();
    s->loop_busy_at_start = loop_busy_s;
    s->id = id_to_resume.empty() ? NewSessionId() : id_to_resume;
    while (id_to_resume.empty() && sessions.count(s->id) != 0) s->id = NewSessionId();
    std::error_code ec;
    const bool existed = fs::exists(s->out(), ec);
    fs::create_directories(s->out(), ec);
    if (ec) {
      throw core::StorageError(s->out().string(),
                               "cannot create the output folder: " + ec.message());
    }
    // A master killed mid-write left temporary files beside what it was writing.
    if (existed) {
      if (const int n = io::RemoveStaleTempFiles(s->out())) {
        spdlog::info("session {}: removed {} temporary files a killed process left in {}", s->id, n,
                     s->out().string());
      }
    }
    try {
      // The session as submitted, derived values included: `dome run OUT/session.json`
      // runs it again with the same options.
      if (!spec.has_noop_jobs())
        io::WriteFileAtomically(s->out() / "session.json", schema::PrintJson(spec) + "\n");
      s->journal =
          std::make_unique<Journal>(s->out() / "journal.log", pipeline::SessionDigest(s->plan));
    } catch (const core::InputError&) {
      // A refused submit leaves nothing behind it made.
      if (!existed) fs::remove_all(s->out(), ec);
      throw;
    }
    s->blobs = std::make_unique<SessionBlobs>(&blobs, s->out() / ".blobs");
    Resume(s.get());
    const std::string id = s->id;
    spdlog::info("session {}: {} instants x {} cameras, {} jobs ({} already done), out {}", id,
                 s->plan.instants.size(), s->plan.cameras.size(), s->graph->size(),
                 s->graph->done(), s->out().string());
    session_order.push_back(id);
    SessionRec* raw = s.get();
    sessions[id] = std::move(s);
    KeepState(*raw, false);
    Publish(*raw, -1, "submitted");
    Advance(raw);
    return id;
  }

  // Refuses a session whose fusion job would need more memory than a worker job may
  // (MasterOptions::max_job_mb): the slab's distances and weights, 8 bytes a voxel.
  void CheckJobMemory(const pipeline::SessionPlan& plan) const {
    int64_t limit_mb = options.max_job_mb;
    if (limit_mb == 0) {
      limit_mb = int64_t(::sysconf(_SC_PHYS_PAGES)) * int64_t(::sysconf(_SC_PAGE_SIZE)) >> 20;
    }
    const fusion::VolumeGrid& g = plan.options.grid;
    const int64_t planes = std::min(plan.options.slab_planes, g.nz);
    const double slab_mb = double(g.PlaneVoxels()) * double(planes) * 8.0 / double(1 << 20);
    core::Require(
        slab_mb <= double(limit_mb), "session volume",
        fmt::format("a fusion job of {} x {} voxels x {} planes needs {:.0f} MiB, more than the "
                    "{} MiB a worker job may use (dome-master --max-job-mb); use larger voxels "
                    "(--voxel-mm), a smaller volume (--box) or fewer planes per job "
                    "(--slab-planes)",
                    g.nx, g.ny, planes, slab_mb, limit_mb));
  }

  // True when a stage that consumes `stage`'s outputs (StageDescriptor::consumes_inputs)
  // is done at `instant` (`done`: whether a node is).
  bool ConsumerDone(const SessionRec* s, int instant, int stage,
                    const std::function<bool(int node)>& done) {
    for (size_t c = 0; c < stages.stages.size(); ++c) {
      const StageDescriptor& d = stages.stages[c];
      if (!d.consumes_inputs ||
          std::find(d.after.begin(), d.after.end(), stages.stages[stage].name) == d.after.end())
        continue;
      const auto& parts = s->graph->stages()[c].parts;
      bool all = !parts.empty();
      for (int p = 0; p < int(parts.size()); ++p)
        all = all && done(s->graph->NodeOf(instant, int(c), p));
      if (all) return true;
    }
    return false;
  }

  // True when the part's outputs are still needed by the same part at the next instant
  // (a stage that runs after its previous instant: time-aware fusion adds each slab's
  // previous evidence), which is not done.
  bool HeldForNext(const SessionRec* s, int instant, int stage, int part,
                   const std::function<bool(int node)>& done) {
    return s->graph->stages()[stage].after_previous_instant &&
           instant + 1 < int(s->plan.instants.size()) &&
           !done(s->graph->NodeOf(instant + 1, stage, part));
  }

  // True when the node's outputs were consumed: its consumer is done and no later job
  // needs them.
  bool Consumed(const SessionRec* s, const JobNode& n, const std::function<bool(int node)>& done) {
    return ConsumerDone(s, n.instant, n.stage, done) &&
           !HeldForNext(s, n.instant, n.stage, n.part, done);
  }

  bool DoneNow(const SessionRec* s, int node) const {
    return s->graph->node(node).state == JobState::kDone;
  }

  // Marks the jobs the journal records as done, when their outputs are still there.
  void Resume(SessionRec* s) {
    // A record stands only for the inputs it was made from: an instant whose frames
    // (or the rig) changed on disk since is redone.
    const auto current = [&](const std::string& key, const JournalEntry& entry) {
      const int node = s->graph->Find(key);
      return node >= 0 && entry.inputs == s->input_digests[s->graph->node(node).instant];
    };
    std::set<std::string> done;
    std::set<int> changed;
    for (const auto& [key, entry] : s->journal->done()) {
      if (current(key, entry)) {
        done.insert(key);
      } else if (const int node = s->graph->Find(key); node >= 0) {
        changed.insert(s->graph->node(node).instant);
      }
    }
    for (int t : changed) {
      spdlog::warn(
          "session {}: instant {}: the take's rig or frames changed since {} recorded "
          "its jobs; redoing them",
          s->id, s->plan.instants[t], (s->out() / "journal.log").string());
    }
    // A job redone that waits for its previous instant's part needs that part's
    // outputs: when they are gone (dropped once the next instant's part had them), that
    // part is redone too, and so on back.
    const auto in_done = [&](int node) { return done.count(s->graph->node(node).key) != 0; };
    const auto on_disk = [&](const std::string& key) {
      std::error_code ec;
      for (const auto& [name, sha] : s->journal->done().at(key).outputs)
        if (!std::filesystem::exists(s->out() / ".blobs" / sha, ec)) return false;
      return true;
    };
    for (int t = int(s->plan.instants.size()) - 1; t > 0; --t) {
      for (int st = 0; st < int(s->graph->stages().size()); ++st) {
        if (!s->graph->stages()[st].after_previous_instant) continue;
        for (int p = 0; p < int(s->graph->stages()[st].parts.size()); ++p) {
          const JobNode& now = s->graph->node(s->graph->NodeOf(t, st, p));
          const JobNode& before = s->graph->node(s->graph->NodeOf(t - 1, st, p));
          if (!done.count(now.key) && done.count(before.key) && !on_disk(before.key))
            done.erase(before.key);
        }
      }
    }
    for (const auto& [key, entry] : s->journal->done()) {
      if (!done.count(key)) continue;
      const int node = s->graph->Find(key);
      const JobNode& n = s->graph->node(node);
      // The outputs of a stage whose consumer is done are gone: its record stands on
      // the consumer's.
      const bool consumed = Consumed(s, n, in_done);
      std::vector<runtime::BlobRef> outs;
      bool ok = true;
      for (const auto& [name, sha] : entry.outputs) {
        if (consumed) break;
        if (!blobs.Adopt(s->out() / ".blobs", sha)) {
          ok = false;
          break;
        }
        auto ref = *blobs.Find(sha);
        ref.set_name(name);
        outs.push_back(ref);
      }
      if (!ok) {
        spdlog::warn("session {}: journal names {} but its output is gone; redoing it", s->id, key);
        continue;
      }
      s->outputs[node] = outs;
      s->graph->MarkDone(node);
      ++s->resumed;
    }
    if (s->resumed > 0) {
      spdlog::info("session {}: resumed from {}: {} jobs already done", s->id,
                   (s->out() / "journal.log").string(), s->resumed);
    }
    // Outputs already there go to the master stages that read them.
    for (const auto& [node, outs] : s->outputs) {
      if (!outs.empty()) FeedMasterStages(s, node, nullptr);
    }
  }

  // Fills in a ready job's inputs (the outputs of the jobs it depends on).
  runtime::Job MakeJob(SessionRec* s, int node, const WorkerRec& w) {
    const JobNode& n = s->graph->node(node);
    runtime::Job job;
    job.set_id(s->id + "/" + n.key);
    job.set_session_id(s->id);
    job.set_instant(s->plan.instants[n.instant]);
    job.set_threads(w.threads);
    job.set_stage(stages.stages[n.stage].name);
    job.set_max_result_bytes(options.socket.max_message_bytes);
    const pipeline::JobContext ctx{
        s->plan, n.instant, n.part,
        [&](const std::string& stage, int part) -> const std::vector<runtime::BlobRef>& {
          return s->outputs.at(s->graph->NodeOf(n.instant, stages.Find(stage), part));
        },
        [&]() -> const std::vector<runtime::BlobRef>& {
          DOME_CHECK(n.instant > 0 && s->graph->stages()[n.stage].after_previous_instant,
                     "a job waits for its previous instant's part");
          return s->outputs.at(s->graph->NodeOf(n.instant - 1, n.stage, n.part));
        }};
    stages.stages[n.stage].make_job(ctx, &job);
    return job;
  }

  // Marks master stages that became ready as running (their runs have every input by
  // then) and finishes sessions.
  void Advance(SessionRec* s) {
    if (!s->running()) return;
    for (int node : std::vector<int>(s->graph->ready().begin(), s->graph->ready().end())) {
      const JobNode& n = s->graph->node(node);
      const StageDescriptor& d = stages.stages[n.stage];
      if (!d.on_master()) continue;
      s->graph->MarkRunning(node);
      Touch(s, node);
      const int input = stages.Find(d.after.at(0));
      for (int p = 0; p < int(s->graph->stages()[input].parts.size()); ++p) {
        const int in = s->graph->NodeOf(n.instant, input, p);
        DOME_CHECK(!s->outputs.at(in).empty(), "a done input of a master stage has its output");
        FeedMasterStages(s, in, nullptr);  // no-op for inputs fed as they came
      }
    }
    if (s->graph->AllDone()) Finish(s);
  }

  // Hands the outputs of `node` to the runs of the master stages that read its stage
  // (started by their first input), unless they are done.
  void FeedMasterStages(SessionRec* s, int node, std::shared_ptr<const void> decoded) {
    const JobNode& n = s->graph->node(node);
    for (int m = 0; m < int(stages.stages.size()); ++m) {
      const StageDescriptor& d = stages.stages[m];
      if (!d.on_master() || d.after.empty() || d.after[0] != stages.stages[n.stage].name ||
          s->graph->stages()[m].parts.empty() ||
          s->graph->node(s->graph->NodeOf(n.instant, m, 0)).state == JobState::kDone)
        continue;
      auto& run = s->master_runs[{n.instant, m}];
      if (!run) {
        run = d.start_on_master({s->plan, n.instant, s->instant_dir(n.instant), s->blobs.get(),
                                 [this] { stage_done.Wake(); }});
      }
      run->Feed(n.part, s->outputs.at(node), decoded);
    }
  }

  // Completes the master stages whose runs have ended.
  void PollMasterStages() {
    for (const auto& id : session_order) {
      SessionRec* s = sessions[id].get();
      for (auto it = s->master_runs.begin(); it != s->master_runs.end();) {
        if (!it->second->Finished()) {
          ++it;
          continue;
        }
        const int node = s->graph->NodeOf(it->first.first, it->first.second, 0);
        std::unique_ptr<pipeline::MasterStageRun> run = std::move(it->second);
        it = s->master_runs.erase(it);
        if (!s->running()) continue;
        try {
          Completed(s, node, run->Result(), run->busy_seconds());
        } catch (const std::exception& e) {
          Fail(s, stages.stages[s->graph->node(node).stage].name + " of " +
                      s->graph->node(node).key + ": " + e.what());
        }
      }
    }
  }

  // Stops the master stages of a session that ended early (their inputs never come).
  static void AbortMasterStages(SessionRec* s) {
    for (auto& [key, run] : s->master_runs) run->Abort();
  }

  void Touch(SessionRec* s, int node) {
    const JobNode& n = s->graph->node(node);
    const double now = s->Now();
    auto& st = s->stage_stats[n.stage];
    if (st.first_start < 0) st.first_start = now;
    auto& is = s->instant_stats[n.instant];
    if (is.first_start < 0) is.first_start = now;
    s->dispatched_at[node] = now;
  }

  // A job's outputs are in their files: journal them, hand them to the master stages
  // that read them, free what is no longer needed, and move the graph on.
  void Completed(SessionRec* s, int node, const std::vector<runtime::BlobRef>& outs,
                 double job_seconds, std::shared_ptr<const void> decoded = nullptr) {
    const JobNode& n = s->graph->node(node);
    const StageDescriptor& d = stages.stages[n.stage];
    JournalEntry entry;
    for (const auto& o : outs) entry.outputs.emplace_back(o.name(), o.sha256());
    entry.inputs = s->input_digests[n.instant];
    s->journal->RecordDone(n.key, entry);  // fsync'd with the loop turn's others
    s->outputs[node] = outs;
    s->running_on.erase(node);
    s->graph->MarkDone(node);
    const double now = s->Now();
    auto& st = s->stage_stats[n.stage];
    const double seconds =
        job_seconds > 0 ? job_seconds
                        : now - (s->dispatched_at.count(node) ? s->dispatched_at[node] : now);
    st.job_seconds += seconds;
    s->instant_stats[n.instant].job_seconds[d.name] += seconds;
    st.last_done = now;
    if (auto in = s->input_bytes.find(node); in != s->input_bytes.end()) {
      // At least 1 KiB: jobs of almost no input are timed by the floor alone.
      const double mib = std::max(double(in->second), 1024.0) / double(1 << 20);
      st.slowest_s_per_mib = std::max(st.slowest_s_per_mib, seconds / mib);
    }
    if (!outs.empty()) FeedMasterStages(s, node, std::move(decoded));
    if (d.consumes_inputs) {
      // Its inputs are in its outputs now; its journal record stands for theirs once it
      // is on disk.
      s->journal->Sync();
      const auto done = [&](int x) { return DoneNow(s, x); };
      for (const std::string& a : d.after) {
        const int input = stages.Find(a);
        for (int p = 0; p < int(s->graph->stages()[input].parts.size()); ++p) {
          if (HeldForNext(s, n.instant, input, p, done)) continue;  // dropped after it
          auto& in = s->outputs[s->graph->NodeOf(n.instant, input, p)];
          for (const auto& b : in) blobs.Drop(b.sha256());
          in.clear();
        }
      }
    }
    if (s->graph->stages()[n.stage].after_previous_instant && n.instant > 0) {
      // The previous instant's part was held for this one.
      const int before = s->graph->NodeOf(n.instant - 1, n.stage, n.part);
      if (Consumed(s, s->graph->node(before), [&](int x) { return DoneNow(s, x); })) {
        auto& in = s->outputs[before];
        for (const auto& b : in) blobs.Drop(b.sha256());
        in.clear();
      }
    }
    if (s->graph->InstantDone(n.instant)) {
      s->instant_stats[n.instant].done = now;
      spdlog::info("session {}: instant {} done ({:.2f} s)", s->id, s->plan.instants[n.instant],
                   now - s->instant_stats[n.instant].first_start);
    }
    Publish(*s, node, "");
    Advance(s);
  }

  void Fail(SessionRec* s, const std::string& error) {
    if (!s->running()) return;
    s->state = SessionState::kFailed;
    s->error = error;
    s->finished_s = s->Now();
    spdlog::error("session {} failed: {}", s->id, error);
    KeepState(*s, true);
    DropQueued(s);
    AbortMasterStages(s);
    Publish(*s, -1, error);
    Retire(s);
  }

  // A session that ended keeps what its status and report need (its plan, graph and
  // counts) and lets go of the rest: its journal (file and records), its bookkeeping of
  // jobs, and the blob store's entries for its take files and outputs that no running
  // session reads (their files stay where they are). Without this every ended session
  // stayed whole in the master for good: an open file and a record per job each, and a
  // blob entry per take file of every take ever submitted.
  void Retire(SessionRec* s) {
    if (s->journal) {
      try {
        s->journal->Sync();
      } catch (const core::InputError& e) {
        spdlog::warn("session {}: {}", s->id, e.what());  // it ended already
      }
      s->journal.reset();
    }
    std::set<std::string> shas = s->input_shas;
    for (const auto& [node, outs] : s->outputs) {
      for (const auto& o : outs) shas.insert(o.sha256());
    }
    ForgetBlobsNoRunningSessionReads(std::move(shas));
    s->outputs.clear();
    s->input_shas.clear();
    s->running_on.clear();
    s->losses.clear();
    s->input_bytes.clear();
    s->dispatched_at.clear();
  }

  // Forgets those of `shas` that no running session reads (as a take file or an output).
  void ForgetBlobsNoRunningSessionReads(std::set<std::string> shas) {
    for (const auto& [id, other] : sessions) {
      if (!other->running()) continue;
      for (const auto& sha : other->input_shas) shas.erase(sha);
      for (const auto& [node, outs] : other->outputs) {
        for (const auto& o : outs) shas.erase(o.sha256());
      }
    }
    for (const auto& sha : shas) blobs.Forget(sha);
  }

  // Forgets the jobs of a session that ended; their workers drop them (a running one
  // runs on: its result is dropped when it comes).
  void DropQueued(SessionRec* s) {
    for (auto& [node, worker] : s->running_on) {
      auto it = workers.find(worker);
      const std::string job = s->id + "/" + s->graph->node(node).key;
      if (it != workers.end() && it->second.Forget(job)) {
        SendDrop(worker, job, "session " + s->id + " is " + StateName(s->state));
      }
    }
    s->running_on.clear();
  }

  void SendDrop(const std::string& worker, const std::string& job, const std::string& reason) {
    runtime::Envelope env;
    env.mutable_drop_job()->set_job_id(job);
    env.mutable_drop_job()->set_reason(reason);
    SendToWorker(worker, env);
  }

  void Finish(SessionRec* s) {
    s->finished_s = s->Now();
    try {
      s->journal->Sync();
      WriteReport(*s);
    } catch (const core::InputError& e) {
      Fail(s, e.what());  // the storage failed under the last records or the report
      return;
    }
    s->state = SessionState::kDone;
    KeepState(*s, true);
    spdlog::info(
        "session {} done in {:.2f} s ({} jobs, {} re-queued, {} duplicate results dropped)", s->id,
        s->finished_s, s->graph->size(), s->requeued, s->duplicates);
    Publish(*s, -1, "done");
    Retire(s);
  }

  void WriteReport(const SessionRec& s) {
    double worker_job_seconds = 0;  // the master's own stages are not a worker's
    for (size_t k = 0; k < stages.stages.size(); ++k) {
      if (!stages.stages[k].on_master()) worker_job_seconds += s.stage_stats[k].job_seconds;
    }
    const double loop_busy = loop_busy_s - s.loop_busy_at_start;
    const int instants = int(s.plan.instants.size());
    core::Json j;
    j["session"] = s.id;
    j["take"] = s.plan.spec.take();
    j["cameras"] = s.plan.cameras.size();
    j["instants"] = instants;
    j["slabs_per_instant"] = s.plan.num_slabs;
    j["jobs"] = s.graph->size();
    j["jobs_resumed_from_journal"] = s.resumed;
    j["jobs_requeued"] = s.requeued;
    j["duplicate_results_dropped"] = s.duplicates;
    j["bytes_to_workers"] = s.bytes_to_workers;
    j["bytes_from_workers"] = s.bytes_from_workers;
    j["seconds"] = (s.finished_s);
    j["seconds_per_instant"] = (s.finished_s / instants);
    j["worker_job_seconds"] = (worker_job_seconds);
    j["master_loop"] = {{"busy_fraction", (s.finished_s > 0 ? loop_busy / s.finished_s : 0)},
                        {"longest_turn_s", (s.loop_longest_turn_s)}};
    core::Json by_stage = core::Json::object();
    for (size_t k = 0; k < stages.stages.size(); ++k) {
      int total = 0;
      for (int t = 0; t < instants; ++t) total += s.graph->Count(t, int(k)).total;
      if (total == 0) continue;
      const auto& st = s.stage_stats[k];
      by_stage[stages.stages[k].name] = {
          {"jobs", total},
          {"job_seconds", (st.job_seconds)},
          {"wall_seconds",
           (st.last_done >= 0 && st.first_start >= 0 ? st.last_done - st.first_start : 0)},
          {"bytes_to_workers", st.bytes_to_workers},
          {"bytes_from_workers", st.bytes_from_workers}};
    }
    j["stages"] = by_stage;
    const fusion::VolumeGrid& g = s.plan.options.grid;
    j["volume"] = {{"origin_mm", {g.origin_mm.x(), g.origin_mm.y(), g.origin_mm.z()}},
                   {"voxel_size_mm", g.voxel_size_mm},
                   {"dims", {g.nx, g.ny, g.nz}}};
    j["derived"] = core::Json(
        std::vector<std::string>(s.plan.spec.derived().begin(), s.plan.spec.derived().end()));
    j["jobs_by_worker"] = s.jobs_by_worker;
    core::Json per_instant = core::Json::array();
    // Clean output over the session: what the decimate stage dropped before decimating
    // (OUT/<instant>/decimation.json, on disk also for instants resumed from the journal).
    int64_t specks = 0, speck_triangles = 0, surface_triangles = 0, decimated = 0;
    // Instants whose surface has no vertex: not an error (an instant may be empty), but
    // usually a volume that misses the scene; counted so that `dome run` can say so.
    std::vector<std::string> empty_surfaces;
    for (int t = 0; t < instants; ++t) {
      const auto& is = s.instant_stats[t];
      core::Json entry = {
          {"instant", s.plan.instants[t]},
          {"seconds", (is.done >= 0 && is.first_start >= 0 ? is.done - is.first_start : 0)},
          {"done_at_seconds", (is.done)},
          {"job_seconds", is.job_seconds}};
      if (const int64_t vertices =
              PlyVertexCount(s.out() / s.plan.instants[t] / pipeline::kMeshPly);
          vertices >= 0) {
        entry["surface_vertices"] = vertices;
        entry["empty_surface"] = vertices == 0;
        if (vertices == 0) empty_surfaces.push_back(s.plan.instants[t]);
      }
      const fs::path summary = s.out() / s.plan.instants[t] / pipeline::kDecimationJson;
      std::error_code ec;
      if (fs::is_regular_file(summary, ec)) {
        try {
          const core::Json d = core::Json::parse(io::ReadFileBytes(summary));
          specks += d.value("specks_removed", int64_t(0));
          speck_triangles += d.value("speck_triangles", int64_t(0));
          surface_triangles += d.value("triangles_in", int64_t(0));
          decimated += 1;
          entry["decimation"] = d;
        } catch (const std::exception& e) {
          spdlog::warn("session {}: {} not read into report.json: {}", s.id, summary.string(),
                       e.what());
        }
      }
      per_instant.push_back(std::move(entry));
    }
    j["per_instant"] = per_instant;
    j["empty_surfaces"] = {{"count", empty_surfaces.size()}, {"instants", empty_surfaces}};
    if (decimated > 0) {
      j["clean"] = {{"instants", decimated},
                    {"specks_removed", specks},
                    {"speck_triangles", speck_triangles},
                    {"speck_triangle_share",
                     surface_triangles > 0 ? double(speck_triangles) / double(surface_triangles)
                                           : 0.0}};
    }
    // NaN figures print as null; worker names and the take path are users' text, and
    // what is not UTF-8 in them is replaced (core/json.h).
    io::WriteFileAtomically(s.out() / "report.json", core::DumpJson(j, 2) + "\n");
  }

  // ---- workers ------------------------------------------------------------------------

  std::string WorkerName(const std::string& id) const {
    auto it = workers.find(id);
    if (it == workers.end()) return net::PeerName(id);
    return "worker " + it->second.name + " (" + net::PeerName(id) + ")";
  }

  // Splits a wire job id into its session and node; nullopt when unknown.
  std::optional<std::pair<SessionRec*, int>> FindJob(const std::string& job_id) {
    const auto slash = job_id.find('/');
    if (slash == std::string::npos) return std::nullopt;
    auto it = sessions.find(job_id.substr(0, slash));
    if (it == sessions.end() || !it->second->graph) return std::nullopt;
    const int node = it->second->graph->Find(job_id.substr(slash + 1));
    if (node < 0) return std::nullopt;
    return std::make_pair(it->second.get(), node);
  }

  void LoseWorker(const std::string& id, const std::string& why) {
    auto it = workers.find(id);
    if (it == workers.end()) return;
    const std::string name = WorkerName(id);
    const std::deque<std::string> jobs = it->second.jobs;
    workers.erase(it);
    if (jobs.empty()) {
      spdlog::warn("{} lost ({}); it was idle", name, why);
      return;
    }
    for (const std::string& job : jobs) Requeue(id, name + " lost (" + why + ")", job, true);
  }

  // A job sent to worker `id` goes back to the ready set: `why` says what happened
  // ("worker ... lost (...)"). Counted as a loss of the job when `count`; the job lost
  // max_job_losses times fails its session, naming the last reason.
  void Requeue(const std::string& id, const std::string& why, const std::string& job, bool count) {
    auto found = FindJob(job);
    if (!found) return;
    auto [s, node] = *found;
    auto running = s->running_on.find(node);
    if (s->graph->node(node).state != JobState::kRunning || running == s->running_on.end() ||
        running->second != id) {
      return;
    }
    s->running_on.erase(node);
    s->graph->Requeue(node);
    ++s->requeued;
    if (!count) {
      spdlog::info("{}; re-queued job {}", why, job);
      return;
    }
    const int losses = ++s->losses[node];
    spdlog::warn("{}; re-queued job {} (lost {} time{})", why, job, losses, losses == 1 ? "" : "s");
    if (losses >= options.max_job_losses) {
      Fail(s,
           "job " + job + " was lost " + std::to_string(losses) + " times; the last time: " + why);
    }
  }

  // The time a worker job may run before it is dropped and re-queued (MasterOptions).
  double JobTimeout(const SessionRec& s, int node) const {
    if (options.job_timeout_s > 0) return options.job_timeout_s;
    auto in = s.input_bytes.find(node);
    const double mib = in == s.input_bytes.end() ? 0 : double(in->second) / double(1 << 20);
    const StageStats& st = s.stage_stats[s.graph->node(node).stage];
    if (st.slowest_s_per_mib < 0) {
      return options.job_timeout_min_s + options.job_timeout_first_s_per_mib * mib;
    }
    return std::max(options.job_timeout_min_s,
                    options.job_timeout_factor * st.slowest_s_per_mib * mib);
  }

  // Drops and re-queues the job each worker runs past its time-out, with the jobs sent
  // ahead to it (those are not counted as lost: they never started).
  void TimeOutJobs() {
    const auto now = Clock::now();
    std::vector<std::tuple<std::string, std::string, double>> late;  // worker, job, limit
    for (const auto& [id, w] : workers) {
      if (w.jobs.empty()) continue;
      auto found = FindJob(w.jobs.front());
      if (!found) continue;
      const double limit = JobTimeout(*found->first, found->second);
      if (Seconds(now - w.front_since) > limit) late.emplace_back(id, w.jobs.front(), limit);
    }
    for (const auto& [id, job, limit] : late) {
      WorkerRec& w = workers.at(id);
      const std::string why = fmt::format(
          "{} did not finish job {} within its time-out of {:.3g} s", WorkerName(id), job, limit);
      const std::deque<std::string> jobs = w.jobs;
      w.jobs.clear();
      w.stuck.insert(job);
      for (const std::string& j : jobs) {
        SendDrop(id, j, j == job ? why : "sent ahead behind a job that timed out");
        Requeue(id, j == job ? why : why + " (sent ahead behind it)", j, j == job);
      }
    }
  }

  void OnWorkerMessage(const std::string& id, runtime::Envelope& env) {
    auto it = workers.find(id);
    const Clock::time_point expiry =
        Clock::now() +
        std::chrono::milliseconds(options.heartbeat_interval_ms * options.heartbeat_liveness);
    if (env.has_hello()) {
      const auto& h = env.hello();
      if (it != workers.end()) LoseWorker(id, "said Hello again");
      WorkerRec w;
      w.id = id;
      w.name = h.name().empty() ? net::PeerName(id) : h.name().substr(0, 200);
      w.threads = std::max(1, std::min(h.threads(), 1024));
      w.cache_mb = h.cache_mb();
      w.expiry = expiry;
      workers[id] = w;
      spdlog::info("worker {} joined ({}, {} threads, {} MB cache); {} workers", w.name,
                   net::PeerName(id), w.threads, w.cache_mb, workers.size());
      return;
    }
    if (it != workers.end()) it->second.expiry = expiry;
    switch (env.body_case()) {
      case runtime::Envelope::kHeartbeat:
        break;
      case runtime::Envelope::kDisconnect:
        LoseWorker(id, "disconnected: " + env.disconnect().reason());
        return;
      case runtime::Envelope::kBlobRequest:
        ServeBlobs(id, env.blob_request());
        break;
      case runtime::Envelope::kResult:
        OnResult(id, std::move(*env.mutable_result()));
        break;
      default:
        throw core::InputError(WorkerName(id), "sent a message a worker may not send");
    }
    if (it == workers.end()) {
      // A worker the master does not know (it was declared lost, or the master
      // restarted): it must say Hello again before it gets work.
      runtime::Envelope bye;
      bye.mutable_disconnect()->set_reason("unknown worker; reconnect and say Hello");
      SendToWorker(id, bye);
    }
  }

  void ServeBlobs(const std::string& id, const runtime::BlobRequest& req) {
    for (const std::string& sha : req.sha256()) {
      runtime::Envelope env;
      auto* b = env.mutable_blob_reply()->add_blobs();
      b->set_sha256(sha.substr(0, 64));
      std::optional<std::string> bytes;
      std::string error;
      if (net::IsSha256Hex(sha)) bytes = blobs.Read(sha, &error);
      if (!bytes && error.empty() && !peer_log.ShouldLog(id + " blob")) {
        b->set_missing(true);  // an unknown blob again: answered, not logged
      } else if (!bytes && !error.empty()) {
        // The file behind a blob the master holds is gone or changed: what depends on
        // it cannot be made from the bytes the session was submitted with.
        BlobLost(sha, error);
        b->set_missing(true);
      } else if (!bytes) {
        spdlog::warn("{}: asked for unknown blob '{}'", WorkerName(id), sha.substr(0, 80));
        b->set_missing(true);
      } else {
        b->set_data(std::move(*bytes));
        auto w = workers.find(id);
        // Blobs are asked for by the job sent last (the others have theirs already).
        if (w != workers.end() && !w->second.jobs.empty()) {
          auto found = FindJob(w->second.jobs.back());
          if (found) {
            SessionRec* s = found->first;
            s->bytes_to_workers += int64_t(b->data().size());
            s->stage_stats[s->graph->node(found->second).stage].bytes_to_workers +=
                int64_t(b->data().size());
          }
        }
      }
      SendToWorker(id, env);
    }
  }

  // Fails every running session that reads the blob `sha256`, whose file `error`
  // says is gone or changed since the session was submitted.
  void BlobLost(const std::string& sha256, const std::string& error) {
    for (const auto& sid : session_order) {
      SessionRec* s = sessions[sid].get();
      if (!s->running()) continue;
      bool reads = s->input_shas.count(sha256) != 0;
      for (const auto& [node, outs] : s->outputs) {
        for (const auto& o : outs) reads = reads || o.sha256() == sha256;
      }
      if (!reads) continue;
      Fail(s, s->input_shas.count(sha256) != 0
                  ? "take file " + error + "; submit the session again to redo what depends on it"
                  : "job output " + error);
    }
  }

  void OnResult(const std::string& id, runtime::JobResult r) {
    const std::string peer = WorkerName(id);
    auto w = workers.find(id);
    if (w != workers.end()) {
      w->second.Forget(r.job_id());
      w->second.stuck.erase(r.job_id());  // a late result: the worker is free again
    }
    auto found = FindJob(r.job_id());
    if (!found) {
      const std::string what = "result for unknown job id '" + r.job_id().substr(0, 200) + "'";
      if (w != workers.end() && !w->second.jobs.empty()) {
        // A job of the master before a restart, finished by a worker that has joined
        // this one and is running a job of ours: that job is not lost.
        spdlog::warn("{}: {} dropped", peer, what);
        return;
      }
      throw core::InputError(peer, what);
    }
    auto [s, node] = *found;
    const JobNode& n = s->graph->node(node);
    if (!s->running()) {
      spdlog::info("{}: result for {} of {} session {} dropped", peer, r.job_id(),
                   StateName(s->state), s->id);
      return;
    }
    if (n.state == JobState::kDone) {
      ++s->duplicates;
      spdlog::info("{}: late or duplicate result for {} dropped", peer, r.job_id());
      return;
    }
    if (StageOf(*s, node).on_master() || n.state == JobState::kWaiting) {
      throw core::InputError(peer, "result for " + r.job_id() + ", which was never dispatched");
    }
    if (!r.ok()) {
      // Jobs are deterministic: an input error on one worker is one on every worker.
      Fail(s, "job " + r.job_id() + " failed on " + peer + ": " + r.error());
      return;
    }
    // Checking, hashing and writing the outputs happens beside the loop; the worker is
    // free for its next job meanwhile. Accepted() takes it from there. The work reads
    // only what the session fixed at its submit (the plan) and the thread-safe store.
    const std::string name = w != workers.end() ? w->second.name : net::PeerName(id);
    auto result = std::make_shared<runtime::JobResult>(std::move(r));
    const pipeline::StoreContext ctx{s->plan,
                                     n.instant,
                                     n.part,
                                     s->instant_dir(n.instant),
                                     peer + " result of " + result->job_id(),
                                     s->blobs.get()};
    const StageDescriptor* stage = &StageOf(*s, node);
    offload.Post([this, s, node, id, peer, name, result, ctx, stage]() -> std::function<void()> {
      try {
        auto stored = std::make_shared<pipeline::StoredResult>(stage->store(ctx, *result));
        return [this, s, node, id, name, result, stored] {
          Accepted(s, node, id, name, *result, *stored);
        };
      } catch (const core::StorageError& e) {
        // The master's disk, not the worker: every result would fail the same way.
        return [this, s, result, what = std::string(e.what())] {
          Fail(s, "cannot store the result of job " + result->job_id() + ": " + what);
        };
      } catch (const std::exception& e) {
        // A result its stage cannot read (an InputError, or a library's own exception
        // on bytes it cannot parse): the worker's fault; another may do better.
        return [this, id, peer, result, what = std::string(e.what())] {
          Requeue(id, peer + " sent a bad result (" + what + ")", result->job_id(), true);
        };
      }
    });
  }

  // A result whose outputs are stored (on the loop's thread again).
  void Accepted(SessionRec* s, int node, const std::string& id, const std::string& name,
                const runtime::JobResult& r, const pipeline::StoredResult& stored) {
    const JobNode& n = s->graph->node(node);
    if (!s->running()) {
      // Stored while the session ended: its entries go as the session's did (Retire).
      std::set<std::string> shas;
      for (const auto& o : stored.outputs) shas.insert(o.sha256());
      ForgetBlobsNoRunningSessionReads(std::move(shas));
      return;
    }
    if (n.state == JobState::kDone) {
      // Another worker's result for the same job was stored first.
      ++s->duplicates;
      spdlog::info("late or duplicate result for {} dropped", r.job_id());
      return;
    }
    // Every output received (files a stage writes rather than stores too).
    for (const auto& o : r.outputs()) {
      s->bytes_from_workers += int64_t(o.data().size());
      s->stage_stats[n.stage].bytes_from_workers += int64_t(o.data().size());
    }
    if (n.state == JobState::kReady) {
      // Requeued after its worker was lost, and now the result came after all.
      s->graph->MarkRunning(node);
    } else if (s->running_on.count(node) && s->running_on[node] != id) {
      auto other = workers.find(s->running_on[node]);
      if (other != workers.end()) other->second.Forget(r.job_id());
    }
    ++s->jobs_by_worker[name];
    try {
      Completed(s, node, stored.outputs, r.seconds(), stored.decoded);
    } catch (const core::InputError& e) {
      Fail(s, "job " + r.job_id() + ": " + e.what());  // its journal record could not be written
    }
  }

  // Idle workers first get the highest-priority ready jobs; then, while ready jobs are
  // left over, busy workers get up to options.jobs_ahead more of the stages that may be
  // sent ahead (many jobs an instant), which they fetch the inputs of while they
  // compute and start the moment their job ends. The long one-per-instant stages are
  // never sent ahead: one waiting behind another job could keep an idle worker idle.
  //
  // A job goes only to a worker whose blob cache holds all its inputs at once; when no
  // worker connected has such a cache, its session fails naming the sizes. Workers
  // still running a job that timed out get work only when every worker is.
  void Dispatch() {
    bool all_stuck = true;
    for (const auto& [id, w] : workers) all_stuck = all_stuck && !w.stuck.empty();
    for (int ahead = 0; ahead <= options.jobs_ahead; ++ahead) {
      for (auto& [id, w] : workers) {
        if (int(w.jobs.size()) != ahead || (!w.stuck.empty() && !all_stuck)) continue;
        SessionRec* best = nullptr;
        int node = -1;
        if (!NextJob(ahead > 0, &best, &node)) return;
        runtime::Job job = MakeJob(best, node, w);
        int64_t bytes = 0;
        for (const auto& b : job.blobs()) bytes += int64_t(b.size());
        if (bytes > (w.cache_mb << 20)) {
          int64_t largest = 0;
          for (const auto& [other, x] : workers) largest = std::max(largest, x.cache_mb);
          if (bytes > (largest << 20)) {
            Fail(best, fmt::format("job {} needs {:.1f} MiB of inputs at once, more than the "
                                   "blob cache of any worker connected (largest: {} MiB; "
                                   "dome-worker --cache-mb)",
                                   job.id(), double(bytes) / double(1 << 20), largest));
            return;  // the next turn dispatches the other sessions' jobs
          }
          continue;  // another worker can take it
        }
        best->graph->MarkRunning(node);
        best->running_on[node] = id;
        best->input_bytes[node] = bytes;
        Touch(best, node);
        w.Add(job.id());
        runtime::Envelope env;
        *env.mutable_job() = std::move(job);
        SendToWorker(id, env);
      }
    }
  }

  // The highest-priority ready job over every running session (oldest first). With
  // `ahead`, none when that job's stage may not be sent ahead: a job sent ahead never
  // passes a higher-priority one (the worker that takes it next must be idle first).
  bool NextJob(bool ahead, SessionRec** best, int* node) {
    for (const auto& sid : session_order) {
      SessionRec* s = sessions[sid].get();
      if (!s->running()) continue;
      for (int n : s->graph->ready()) {
        const StageDescriptor& d = StageOf(*s, n);
        if (d.on_master()) continue;
        if (ahead && !d.send_ahead) return false;
        *best = s;
        *node = n;
        return true;
      }
    }
    return false;
  }

  // ---- control ------------------------------------------------------------------------

  runtime::SessionStatus Status(const SessionRec& s) const {
    runtime::SessionStatus st;
    st.set_id(s.id);
    st.set_state(StateName(s.state));
    st.set_take(s.plan.spec.take());
    st.set_out(s.plan.spec.out());
    st.set_error(s.error);
    st.set_elapsed_s(s.finished_s >= 0 ? s.finished_s : s.Now());
    st.set_workers(int(workers.size()));
    if (!s.graph) return st;
    st.set_jobs_done(s.graph->done());
    st.set_jobs_total(s.graph->size());
    for (int t = 0; t < int(s.plan.instants.size()); ++t) {
      auto* is = st.add_instants();
      is->set_instant(s.plan.instants[t]);
      is->set_done(s.graph->InstantDone(t));
      for (int k = 0; k < int(stages.stages.size()); ++k) {
        const StageCount c = s.graph->Count(t, k);
        if (c.total == 0) continue;
        auto* sp = is->add_stages();
        sp->set_stage(stages.stages[k].name);
        sp->set_done(c.done);
        sp->set_total(c.total);
      }
    }
    return st;
  }

  // A submit is planned beside the loop (reading and hashing every frame of the take:
  // 2.9 s for 8,000 instants, long enough for the loop to miss its workers' heartbeats)
  // and started on it; the client gets its answer then.
  void SubmitBesideTheLoop(const std::string& peer_id, bool req, const runtime::Session& spec) {
    offload.Post([this, peer_id, req, spec]() -> std::function<void()> {
      auto prepared = std::make_shared<std::unique_ptr<SessionRec>>();
      std::string error;
      try {
        *prepared = Prepare(spec);
      } catch (const core::InputError& e) {
        error = e.what();
      } catch (const std::exception& e) {
        error = std::string("master: ") + e.what();
      }
      return [this, peer_id, req, spec, prepared, error] {
        runtime::ControlReply reply;
        reply.set_ok(error.empty());
        reply.set_error(error);
        if (error.empty()) {
          try {
            reply.set_session_id(Start(spec, std::move(*prepared)));
            *reply.add_sessions() = Status(*sessions[reply.session_id()]);
          } catch (const std::exception& e) {
            reply.set_ok(false);
            reply.set_error(dynamic_cast<const core::InputError*>(&e)
                                ? std::string(e.what())
                                : std::string("master: ") + e.what());
          }
        }
        runtime::Envelope env;
        *env.mutable_control_reply() = reply;
        Reply(&control_socket, peer_id, req, env);
      };
    });
  }

  // Status, cancel and list (a submit: SubmitBesideTheLoop).
  runtime::ControlReply OnControl(const runtime::ControlRequest& req) {
    runtime::ControlReply reply;
    reply.set_ok(true);
    try {
      switch (req.kind_case()) {
        case runtime::ControlRequest::kStatus:
        case runtime::ControlRequest::kCancel: {
          const std::string& id =
              req.has_status() ? req.status().session_id() : req.cancel().session_id();
          if (id.empty() && req.has_status()) {
            for (const auto& sid : session_order) *reply.add_sessions() = Status(*sessions[sid]);
            break;
          }
          auto it = sessions.find(id);
          core::Require(it != sessions.end(), "session id",
                        "no session '" + id.substr(0, 100) + "'");
          SessionRec* s = it->second.get();
          if (req.has_cancel() && s->running()) {
            s->state = SessionState::kCancelled;
            s->finished_s = s->Now();
            KeepState(*s, true);
            DropQueued(s);
            AbortMasterStages(s);
            spdlog::info("session {} cancelled", id);
            Publish(*s, -1, "cancelled");
            Retire(s);
          }
          reply.set_session_id(id);
          *reply.add_sessions() = Status(*s);
          break;
        }
        case runtime::ControlRequest::kList:
          for (const auto& sid : session_order) *reply.add_sessions() = Status(*sessions[sid]);
          break;
        default:
          throw core::InputError("control request",
                                 "names no request (submit, status, cancel, list)");
      }
    } catch (const core::InputError& e) {
      reply.set_ok(false);
      reply.set_error(e.what());
    } catch (const std::exception& e) {
      reply.set_ok(false);
      reply.set_error(std::string("master: ") + e.what());
    }
    return reply;
  }

  // ---- loop -------------------------------------------------------------------------

  void HandleWorkerSocket() {
    for (int budget = 0; budget < 1000; ++budget) {
      std::vector<zmq::message_t> frames = net::ReceiveFrames(&workers_socket);
      if (frames.empty()) return;
      const std::string id = frames[0].to_string();
      if (frames.size() != 2) {
        if (auto n = peer_log.ShouldLog(id + " frames")) {
          spdlog::warn("{}: refused a message of {} frames on the worker socket (expected 1){}",
                       net::PeerName(id), frames.size() - 1, net::LogThrottle::Repeats(*n));
        }
        Refuse(&workers_socket, id, "expected one frame per message", false);
        continue;
      }
      try {
        runtime::Envelope env = net::DecodeEnvelope(frames[1].to_string_view(), WorkerName(id),
                                                    options.socket.max_message_bytes);
        OnWorkerMessage(id, env);
      } catch (const core::InputError& e) {
        if (auto n = peer_log.ShouldLog(id + " " + Cause(e.what()))) {
          spdlog::warn("refused on the worker socket: {}{}", e.what(),
                       net::LogThrottle::Repeats(*n));
        }
        Refuse(&workers_socket, id, e.what(), false);
        // A known worker's refused message may have been its result (over the cap):
        // its job would never finish, so it counts as lost with that worker.
        auto w = workers.find(id);
        if (w != workers.end() && !w->second.jobs.empty()) {
          LoseWorker(id, std::string("sent a refused message: ") + e.what());
        }
      } catch (const std::exception& e) {
        // Not the peer's fault (a file system error writing outputs...): say so, go on.
        spdlog::error("{}: message not handled: {}", WorkerName(id), e.what());
      }
    }
  }

  void HandleControlSocket() {
    for (int budget = 0; budget < 1000; ++budget) {
      std::vector<zmq::message_t> frames = net::ReceiveFrames(&control_socket);
      if (frames.empty()) return;
      const std::string id = frames[0].to_string();
      const std::string peer = "control " + net::PeerName(id);
      // REQ clients: [id, empty, payload]; DEALER clients: [id, payload].
      const bool req = frames.size() == 3 && frames[1].size() == 0;
      if (!(req || frames.size() == 2)) {
        if (auto n = peer_log.ShouldLog(id + " frames")) {
          spdlog::warn("{}: refused a message of {} frames on the control socket{}", peer,
                       frames.size() - 1, net::LogThrottle::Repeats(*n));
        }
        Refuse(&control_socket, id, "expected [empty, request] frames", frames.size() >= 3);
        continue;
      }
      runtime::ControlReply reply;
      try {
        const runtime::Envelope env = net::DecodeEnvelope(frames.back().to_string_view(), peer,
                                                          options.socket.max_message_bytes);
        core::Require(env.has_control(), peer, "sent a message that is not a control request");
        if (env.control().has_submit()) {
          SubmitBesideTheLoop(id, req, env.control().submit().session());
          continue;  // answered when planned
        }
        reply = OnControl(env.control());
      } catch (const core::InputError& e) {
        if (auto n = peer_log.ShouldLog(id + " " + Cause(e.what()))) {
          spdlog::warn("refused on the control socket: {}{}", e.what(),
                       net::LogThrottle::Repeats(*n));
        }
        Refuse(&control_socket, id, e.what(), req);
        continue;
      }
      runtime::Envelope env;
      *env.mutable_control_reply() = reply;
      Reply(&control_socket, id, req, env);
    }
  }

  void Run(const std::atomic<bool>* stop) {
    const int interval = options.heartbeat_interval_ms;
    while (!stop->load()) {
      zmq::pollitem_t items[] = {
          {workers_socket.handle(), 0, ZMQ_POLLIN, 0},
          {control_socket.handle(), 0, ZMQ_POLLIN, 0},
          {events_socket.handle(), 0, ZMQ_POLLIN, 0},
          {nullptr, stage_done.read_fd(), ZMQ_POLLIN, 0},
          {capture_ingest ? capture_ingest->socket().handle() : nullptr, 0, ZMQ_POLLIN, 0}};
      // Back soon while work beside the loop is out, so that its outcome is acted on.
      const int wait_ms = offload.pending() > 0 ? 1 : std::min(interval, 20);
      try {
        zmq::poll(items, capture_ingest ? 5 : 4, std::chrono::milliseconds(wait_ms));
      } catch (const zmq::error_t& e) {
        if (e.num() != EINTR) throw;
        continue;  // a signal; *stop says whether to go on
      }
      if (items[3].revents & ZMQ_POLLIN) stage_done.Drain();  // PollMasterStages below
      const auto turn_start = Clock::now();
      if (items[0].revents & ZMQ_POLLIN) HandleWorkerSocket();
      // The workers' messages that came before this are read: a worker is silent when
      // its last one is older than the liveness as of now, not as of the end of this
      // turn, whose work (a result's completion, a session started) may outlast the
      // liveness while the workers' heartbeats wait in the socket for the next turn.
      const auto heard = Clock::now();
      if (items[1].revents & ZMQ_POLLIN) HandleControlSocket();
      if (items[2].revents & ZMQ_POLLIN) subscribers->Receive();
      if (capture_ingest && (items[4].revents & ZMQ_POLLIN)) capture_ingest->Poll(0);
      if (options.release_memory_s > 0 && now_trim <= Clock::now()) {
        // Memory a peer's messages took (a flood of large ones) goes back to the system
        // rather than staying in the heap for good.
        core::ReleaseFreedMemory();
        now_trim = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                      std::chrono::duration<double>(options.release_memory_s));
      }
      offload.Collect();
      PollMasterStages();
      const auto now = Clock::now();
      std::vector<std::string> expired;
      for (const auto& [id, w] : workers) {
        if (heard > w.expiry) expired.push_back(id);
      }
      for (const auto& id : expired) {
        LoseWorker(id, "no heartbeat for " + std::to_string(interval * options.heartbeat_liveness) +
                           " ms");
      }
      if (now >= next_heartbeat) {
        runtime::Envelope hb;
        hb.mutable_heartbeat();
        for (const auto& [id, w] : workers) SendToWorker(id, hb);
        next_heartbeat = now + std::chrono::milliseconds(interval);
        subscribers->Expire();
      }
      TimeOutJobs();
      Dispatch();
      if (Clock::now() >= next_journal_sync) {
        SyncJournals();
        next_journal_sync = Clock::now() + kJournalSyncInterval;
      }
      const double turn = Seconds(Clock::now() - turn_start);
      loop_busy_s += turn;
      for (auto& [id, s] : sessions) {
        if (s->running()) s->loop_longest_turn_s = std::max(s->loop_longest_turn_s, turn);
      }
    }
    SyncJournals();
    StopMasterStages();
  }

  void SyncJournals() {
    for (auto& [id, s] : sessions) {
      if (!s->journal || s->journal->unsynced() == 0) continue;
      try {
        s->journal->Sync();
      } catch (const core::InputError& e) {
        Fail(s.get(), e.what());
      }
    }
  }

  // Stops every master stage's run before the blob store they read goes away.
  void StopMasterStages() {
    for (auto& [id, s] : sessions) {
      AbortMasterStages(s.get());
      s->master_runs.clear();
    }
  }

  ~Impl() { StopMasterStages(); }
};

Master::Master(zmq::context_t* context, const MasterOptions& options)
    : impl_(std::make_unique<Impl>(context, options)) {}
Master::~Master() = default;
const MasterEndpoints& Master::endpoints() const { return impl_->endpoints; }
void Master::Run(const std::atomic<bool>* stop) { impl_->Run(stop); }

}  // namespace dome::scheduler
