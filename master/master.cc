#include "master/master.h"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <set>
#include <thread>
#include <vector>

#include "core/error.h"
#include "fusion/volume.h"
#include "io/file_util.h"
#include "io/ply.h"
#include "net/security.h"
#include "net/content_hash.h"
#include "pipeline/session.h"
#include "pipeline/stages.h"
#include "master/blob_store.h"
#include "master/capture_host.h"
#include "master/graph.h"
#include "master/journal.h"
#include "master/surface_stream.h"
#include "stereo/cluster.h"
#include "stereo/take_stereo.h"
#include "take/take.h"

namespace dome::scheduler {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

void MasterOptions::Check() const {
  core::Require(heartbeat_interval_ms > 0, "heartbeat_interval_ms",
                "must be positive, got " + std::to_string(heartbeat_interval_ms));
  core::Require(heartbeat_liveness > 0, "heartbeat_liveness",
                "must be positive, got " + std::to_string(heartbeat_liveness));
  core::Require(max_job_losses > 0, "max_job_losses", "must be positive");
  core::Require(jobs_ahead >= 0 && jobs_ahead <= 16, "jobs_ahead",
                "must be in 0..16, got " + std::to_string(jobs_ahead));
  core::Require(
      writer_threads >= 0 && writer_threads <= 256, "writer_threads",
      "must be in 0..256 (0 = half the hardware threads), got " + std::to_string(writer_threads));
  socket.Check();
}

namespace {

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

std::string Num(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

std::string NewSessionId() {
  static std::mt19937_64 rng(std::random_device{}());
  char buf[17];
  std::snprintf(buf, sizeof buf, "%08llx", (unsigned long long)(rng() & 0xffffffffULL));
  return buf;
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
  bool Forget(const std::string& job_id) {
    auto it = std::find(jobs.begin(), jobs.end(), job_id);
    if (it == jobs.end()) return false;
    jobs.erase(it);
    return true;
  }
};

struct StageStats {
  double job_seconds = 0;                                // summed over jobs
  double first_start = -1, last_done = -1;               // seconds since the session started
  int64_t bytes_to_workers = 0, bytes_from_workers = 0;  // blobs served, outputs received
};

struct InstantStats {
  double first_start = -1, done = -1;
};

struct SessionRec {
  std::string id;
  int seq = 0;
  runtime::Session spec;
  pipeline::SessionOptions options;
  take::Take take;
  std::vector<std::string> cameras;
  std::unique_ptr<JobGraph> graph;
  std::unique_ptr<Journal> journal;
  std::map<int, std::vector<runtime::BlobRef>> outputs;  // node -> output blobs (by name order)
  std::map<int, std::string> running_on;                 // node -> worker id
  std::map<int, int> losses;                             // node -> workers lost with it
  std::map<int, double> dispatched_at;
  std::string state = "running";
  std::string error;
  Clock::time_point start = Clock::now();
  double finished_s = -1;
  std::array<StageStats, kNumStages> stage_stats;
  std::vector<InstantStats> instant_stats;
  int num_slabs = 0;
  runtime::BlobRef rig;
  std::vector<std::vector<runtime::BlobRef>> frames;  // [instant][camera]
  int64_t bytes_to_workers = 0, bytes_from_workers = 0;
  int requeued = 0, duplicates = 0, resumed = 0;
  std::map<std::string, int> jobs_by_worker;  // worker name -> results accepted from it
  // instant -> its surface stage, fed slabs as they finish (surface_stream.h).
  std::map<int, std::unique_ptr<SurfaceStream>> surface;
  // The master loop while this session ran: its busy seconds when the session started
  // (the loop's running total), and its longest turn since.
  double loop_busy_at_start = 0, loop_longest_turn_s = 0;

  fs::path out() const { return spec.out(); }
  fs::path blob_dir() const { return out() / ".blobs"; }
  double Now() const { return Seconds(Clock::now() - start); }
};

// Work handed off the loop (checking, hashing and writing a result's files) to a pool
// of threads, started in the order posted. Each piece of work returns what the loop
// does with its outcome; Collect() runs those on the loop's thread, in the order they
// finished (results are independent; two results of one job are told apart by the
// loop). Work still queued when the master stops is dropped (its results were never
// journalled: they are redone).
class Offload {
 public:
  using Work = std::function<std::function<void()>()>;
  explicit Offload(int threads) {
    for (int t = 0; t < threads; ++t) threads_.emplace_back([this] { Loop(); });
  }
  ~Offload() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    for (auto& t : threads_) t.join();
  }
  void Post(Work work) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      queue_.push_back(std::move(work));
      ++pending_;
    }
    cv_.notify_one();
  }
  // Runs the completions of the work finished so far (on the caller's thread).
  void Collect() {
    std::deque<std::function<void()>> done;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done.swap(done_);
      pending_ -= int(done.size());
    }
    for (auto& then : done) {
      try {
        then();
      } catch (const std::exception& e) {
        spdlog::error("master: acting on work done beside the loop failed: {}", e.what());
      }
    }
  }
  // Work posted whose completion has not been collected.
  int pending() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return pending_;
  }

 private:
  void Loop() {
    while (true) {
      Work work;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
        if (stop_) return;
        work = std::move(queue_.front());
        queue_.pop_front();
      }
      std::function<void()> then;
      try {
        then = work();
      } catch (const std::exception& e) {
        // Work reports its own errors; this is a bug or the file system failing.
        then = [what = std::string(e.what())] {
          spdlog::error("master: work beside the loop failed: {}", what);
        };
      }
      std::lock_guard<std::mutex> lock(mutex_);
      done_.push_back(std::move(then));
    }
  }

  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Work> queue_;
  std::deque<std::function<void()>> done_;
  int pending_ = 0;
  bool stop_ = false;
  std::vector<std::thread> threads_;  // last: they start after the members they use
};

// A journal is fsync'd at most this often (journal.h): one fsync costs milliseconds on
// the loop, and records lost to a power cut only redo their (idempotent) jobs.
constexpr auto kJournalSyncInterval = std::chrono::milliseconds(50);

}  // namespace

struct Master::Impl {
  zmq::context_t* context;
  MasterOptions options;
  MasterEndpoints endpoints;
  zmq::socket_t workers_socket, control_socket, events_socket;
  std::unique_ptr<net::HandshakeLog> handshake_log;  // after the sockets: destroyed first
  std::map<std::string, WorkerRec> workers;
  std::map<std::string, std::unique_ptr<SessionRec>> sessions;
  std::vector<std::string> session_order;
  std::unique_ptr<ingest::FrameIngest> capture_ingest;  // with capture_endpoint
  BlobStore blobs;
  int next_seq = 0;
  Clock::time_point next_heartbeat = Clock::now();
  Clock::time_point next_journal_sync = Clock::now();
  double loop_busy_s = 0;  // the loop's time outside poll, summed over its turns
  // Last member: destroyed first, so its threads stop before what their work touches.
  Offload offload;

  Impl(zmq::context_t* ctx, const MasterOptions& o)
      : context(ctx),
        options(o),
        workers_socket(*ctx, zmq::socket_type::router),
        control_socket(*ctx, zmq::socket_type::router),
        events_socket(*ctx, zmq::socket_type::pub),
        offload(WriterThreads(o)) {
    options.Check();
    Bind(&workers_socket, options.worker_endpoint, "--bind", &endpoints.workers);
    Bind(&control_socket, options.control_endpoint, "--control", &endpoints.control);
    Bind(&events_socket, options.events_endpoint, "--events", &endpoints.events);
    handshake_log = std::make_unique<net::HandshakeLog>(
        ctx,
        std::vector<std::pair<zmq::socket_t*, std::string>>{
            {&workers_socket, "worker"}, {&control_socket, "control"}, {&events_socket, "events"}});
    if (!options.capture_endpoint.empty()) {
      capture_ingest =
          HostCaptureIngest(context, options.capture_endpoint, options.capture_take, options.socket,
                            [this](const runtime::StatusEvent& ev) {
                              runtime::Envelope env;
                              *env.mutable_status() = ev;
                              net::SendFrames(&events_socket, {net::EncodeEnvelope(env)});
                            });
      endpoints.capture = capture_ingest->endpoint();
    }
  }

  static int WriterThreads(const MasterOptions& o) {
    o.Check();
    if (o.writer_threads > 0) return o.writer_threads;
    return std::max(1, int(std::thread::hardware_concurrency()) / 2);
  }

  void Bind(zmq::socket_t* s, const std::string& endpoint, const std::string& flag,
            std::string* bound) {
    net::ConfigureSocket(s, options.socket);
    if (s == &workers_socket) s->set(zmq::sockopt::router_mandatory, 1);
    try {
      s->bind(endpoint);
    } catch (const zmq::error_t& e) {
      throw core::InputError(flag + " " + endpoint, std::string("cannot bind: ") + e.what());
    }
    *bound = net::BoundEndpoint(*s);
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

  void Refuse(zmq::socket_t* s, const std::string& id, const std::string& reason, bool req) {
    runtime::Envelope env;
    env.mutable_refusal()->set_reason(reason);
    const std::string bytes = net::EncodeEnvelope(env);
    try {
      if (req) {
        net::SendFrames(s, {id, "", bytes});
      } else {
        net::SendFrames(s, {id, bytes});
      }
    } catch (const zmq::error_t&) {
    }
  }

  void Publish(const SessionRec& s, int instant, Stage stage, const std::string& message) {
    runtime::Envelope env;
    auto* ev = env.mutable_status();
    ev->set_session_id(s.id);
    ev->set_state(s.state);
    ev->set_elapsed_s(s.finished_s >= 0 ? s.finished_s : s.Now());
    if (s.graph) {
      ev->set_jobs_done(s.graph->done());
      ev->set_jobs_total(s.graph->size());
      if (instant >= 0) {
        ev->set_instant(s.graph->instants()[instant]);
        ev->set_stage(StageName(stage));
        const StageCount c = s.graph->Count(instant, stage);
        ev->set_done(c.done);
        ev->set_total(c.total);
      }
    }
    ev->set_message(message);
    const std::string bytes = net::EncodeEnvelope(env);
    net::SendFrames(&events_socket, {bytes});
  }

  // ---- sessions -----------------------------------------------------------------------

  // The digest the journal is keyed on: the take, the instants and every resolved
  // option (not the session id, not the output folder).
  static std::string SessionDigest(const SessionRec& s) {
    runtime::Session canon;
    // No take for benchmark sessions of no-op jobs (fs::absolute throws on "").
    if (!s.take.dir.empty()) canon.set_take(fs::absolute(s.take.dir).lexically_normal().string());
    for (const auto& in : s.graph->instants()) canon.add_instants(in);
    *canon.mutable_stereo() = stereo::ToStereoSettings(s.options.stereo);
    *canon.mutable_volume() = pipeline::ToVolume(s.options.grid);
    *canon.mutable_fusion() = pipeline::ToFusionSettings(s.options.fusion);
    canon.set_slab_planes(s.options.slab_planes);
    canon.set_decimate_ratio(s.options.decimate_ratio);
    canon.set_texture(s.options.texture);
    canon.set_smooth_iterations(s.options.smooth.iterations);
    canon.set_smooth_lambda(s.options.smooth.lambda);
    canon.set_smooth_mu(s.options.smooth.mu);
    canon.set_write_previews(s.options.stereo.write_previews);
    canon.set_noop_jobs(s.spec.noop_jobs());
    std::string bytes;
    google::protobuf::io::StringOutputStream stream(&bytes);
    google::protobuf::io::CodedOutputStream coded(&stream);
    coded.SetSerializationDeterministic(true);
    canon.SerializeToCodedStream(&coded);
    coded.Trim();
    return net::Sha256Hex(bytes);
  }

  std::string Submit(const runtime::Session& spec) {
    auto s = std::make_unique<SessionRec>();
    s->loop_busy_at_start = loop_busy_s;
    s->id = NewSessionId();
    while (sessions.count(s->id) != 0) s->id = NewSessionId();
    s->seq = next_seq++;
    s->spec = spec;
    core::Require(!spec.out().empty(), "session: out", "names no output folder");
    s->options = pipeline::ResolveSessionOptions(spec, "session");
    std::error_code ec;
    fs::create_directories(s->out(), ec);
    core::Require(!ec, s->out().string(), "cannot create the output folder: " + ec.message());
    if (spec.noop_jobs() > 0) {
      s->graph = std::make_unique<JobGraph>(JobGraph::Noop(spec.noop_jobs()));
      s->instant_stats.resize(1);
    } else {
      core::Require(!spec.take().empty(), "session: take", "names no take folder");
      s->take = take::OpenTake(spec.take());
      const std::vector<std::string> instants = pipeline::SessionInstants(spec, s->take);
      core::Require(!instants.empty(), spec.take(), "has no instants");
      for (const auto& rc : s->take.rig.cameras) s->cameras.push_back(rc.model.id);
      s->num_slabs = (s->options.grid.nz + s->options.slab_planes - 1) / s->options.slab_planes;
      s->graph = std::make_unique<JobGraph>(instants, s->cameras, s->num_slabs);
      s->instant_stats.resize(instants.size());
      // Stereo clusters now, so that a bad rig fails the submit, not a worker.
      for (const auto& c : s->cameras) {
        stereo::SelectCluster(s->take.rig, c, s->options.stereo.cluster);
      }
      s->rig = blobs.AddFile(s->take.RigPath(), "rig.json");
      for (const auto& in : instants) {
        std::vector<runtime::BlobRef> row;
        for (const auto& c : s->cameras) {
          row.push_back(blobs.AddFile(s->take.FramePath(in, c), "frames/" + in + "/" + c + ".png"));
        }
        s->frames.push_back(std::move(row));
      }
    }
    s->journal = std::make_unique<Journal>(s->out() / "journal.log", SessionDigest(*s));
    Resume(s.get());
    const std::string id = s->id;
    spdlog::info(
        "session {}: {} instants x {} cameras, {} slabs each, {} jobs ({} already done), "
        "out {}",
        id, s->graph->instants().size(), s->cameras.size(), s->num_slabs, s->graph->size(),
        s->graph->done(), s->out().string());
    session_order.push_back(id);
    SessionRec* raw = s.get();
    sessions[id] = std::move(s);
    Publish(*raw, -1, Stage::kStereo, "submitted");
    Advance(raw);
    return id;
  }

  // Marks the jobs the journal records as done, when their outputs are still there.
  void Resume(SessionRec* s) {
    // Slab outputs are dropped once their instant's surface is done; a journal's
    // fusion records then stand on the surface record.
    std::set<int> surfaced;
    for (const auto& [key, entry] : s->journal->done()) {
      const int node = s->graph->Find(key);
      if (node >= 0 && s->graph->node(node).stage == Stage::kSurface) {
        surfaced.insert(s->graph->node(node).instant);
      }
    }
    for (const auto& [key, entry] : s->journal->done()) {
      const int node = s->graph->Find(key);
      if (node < 0) continue;
      const JobNode& n = s->graph->node(node);
      std::vector<runtime::BlobRef> outs;
      bool ok = true;
      for (const auto& [name, sha] : entry.outputs) {
        if (n.stage == Stage::kFusion && surfaced.count(n.instant) != 0) break;
        if (!blobs.Adopt(s->blob_dir(), sha)) {
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
    // Slabs already done go to their instant's surface stream now.
    for (const auto& [node, outs] : s->outputs) {
      const JobNode& n = s->graph->node(node);
      if (n.stage == Stage::kFusion && !outs.empty()) FeedSurface(s, n.instant, n.part, outs[0]);
    }
  }

  // Fills in a ready job's inputs (the outputs of the jobs it depends on).
  runtime::Job MakeJob(SessionRec* s, int node, const WorkerRec& w) {
    const JobNode& n = s->graph->node(node);
    runtime::Job job;
    job.set_id(s->id + "/" + n.key);
    job.set_session_id(s->id);
    job.set_instant(s->graph->instants()[n.instant]);
    job.set_threads(w.threads);
    auto add = [&](const runtime::BlobRef& b) { *job.add_blobs() = b; };
    switch (n.stage) {
      case Stage::kStereo: {
        auto* sj = job.mutable_stereo();
        sj->set_camera(s->cameras[n.part]);
        *sj->mutable_stereo() = stereo::ToStereoSettings(s->options.stereo);
        sj->set_write_previews(s->options.stereo.write_previews);
        const auto& frames = s->frames[n.instant];
        add(s->rig);
        add(frames[n.part]);
        for (int j :
             stereo::SelectCluster(s->take.rig, s->cameras[n.part], s->options.stereo.cluster)) {
          sj->add_neighbours(s->cameras[j]);
          add(frames[j]);
        }
        break;
      }
      case Stage::kFusion: {
        auto* fj = job.mutable_fusion();
        fj->set_k0(n.part * s->options.slab_planes);
        fj->set_k1(std::min(s->options.grid.nz, (n.part + 1) * s->options.slab_planes));
        *fj->mutable_volume() = pipeline::ToVolume(s->options.grid);
        *fj->mutable_fusion() = pipeline::ToFusionSettings(s->options.fusion);
        add(s->rig);
        for (int c = 0; c < int(s->cameras.size()); ++c) {
          add(s->outputs.at(
              s->graph->Find(s->graph->instants()[n.instant] + "/stereo/" + s->cameras[c]))[0]);
        }
        break;
      }
      case Stage::kDecimate:
        job.mutable_decimate()->set_ratio(s->options.decimate_ratio);
        add(s->outputs.at(node - 1)[0]);  // the surface
        break;
      case Stage::kTexture:
        job.mutable_texture()->set_atlas(s->options.texture);
        add(s->rig);
        add(s->outputs.at(node - 1)[0]);  // the decimated mesh
        for (const auto& f : s->frames[n.instant]) add(f);
        break;
      case Stage::kNoop:
        job.mutable_noop();
        break;
      case Stage::kSurface:
        DOME_CHECK(false, "the surface is the master's stage");
    }
    return job;
  }

  // Marks master-side stages that became ready as running (their surface streams have
  // every slab by then) and finishes instants and sessions.
  void Advance(SessionRec* s) {
    if (s->state != "running") return;
    for (int node : std::vector<int>(s->graph->ready().begin(), s->graph->ready().end())) {
      const JobNode& n = s->graph->node(node);
      if (n.stage != Stage::kSurface) continue;
      s->graph->MarkRunning(node);
      Touch(s, node);
      for (int k = 0; k < s->num_slabs; ++k) {
        const auto& outs = s->outputs.at(FusionNode(s, n.instant, k));
        DOME_CHECK(!outs.empty(), "a done slab has its output");
        FeedSurface(s, n.instant, k, outs[0]);  // no-op for slabs fed as they came
      }
    }
    if (s->graph->AllDone()) Finish(s);
  }

  int FusionNode(const SessionRec* s, int instant, int slab) const {
    return s->graph->Find(s->graph->instants()[instant] + "/fusion/" + std::to_string(slab));
  }

  // Hands a finished slab to its instant's surface stream, started by the first slab.
  void FeedSurface(SessionRec* s, int instant, int slab, const runtime::BlobRef& blob,
                   std::shared_ptr<const fusion::Slab> decoded = nullptr) {
    auto& stream = s->surface[instant];
    if (!stream) {
      stream =
          std::make_unique<SurfaceStream>(s->options.grid, s->num_slabs, &blobs,
                                          s->out() / s->graph->instants()[instant], s->blob_dir(),
                                          s->options.smooth);
    }
    stream->Feed(slab, blob.sha256(), std::move(decoded));
  }

  // Completes the surface stages whose streams have ended.
  void PollSurfaces() {
    for (const auto& id : session_order) {
      SessionRec* s = sessions[id].get();
      for (auto it = s->surface.begin(); it != s->surface.end();) {
        if (!it->second->Finished()) {
          ++it;
          continue;
        }
        const int node = s->graph->Find(s->graph->instants()[it->first] + "/surface");
        std::unique_ptr<SurfaceStream> stream = std::move(it->second);
        it = s->surface.erase(it);
        if (s->state != "running") continue;
        try {
          const runtime::BlobRef mesh = stream->Result();
          Completed(s, node, {mesh}, stream->busy_seconds());
        } catch (const std::exception& e) {
          Fail(s, "surface of " + s->graph->node(node).key + ": " + e.what());
        }
      }
    }
  }

  // Stops the surface streams of a session that ended early (their slabs never come).
  static void AbortSurfaces(SessionRec* s) {
    for (auto& [instant, stream] : s->surface) stream->Abort();
  }

  void Touch(SessionRec* s, int node) {
    const JobNode& n = s->graph->node(node);
    const double now = s->Now();
    auto& st = s->stage_stats[int(n.stage)];
    if (st.first_start < 0) st.first_start = now;
    auto& is = s->instant_stats[n.instant];
    if (is.first_start < 0) is.first_start = now;
    s->dispatched_at[node] = now;
  }

  // A job's outputs are in their files: journal them, free what is no longer needed,
  // feed a slab to its surface stream, and move the graph on.
  void Completed(SessionRec* s, int node, const std::vector<runtime::BlobRef>& outs,
                 double job_seconds, std::shared_ptr<const fusion::Slab> slab = nullptr) {
    const JobNode& n = s->graph->node(node);
    JournalEntry entry;
    for (const auto& o : outs) entry.outputs.emplace_back(o.name(), o.sha256());
    s->journal->RecordDone(n.key, entry);  // fsync'd with the loop turn's others
    s->outputs[node] = outs;
    s->running_on.erase(node);
    s->graph->MarkDone(node);
    const double now = s->Now();
    auto& st = s->stage_stats[int(n.stage)];
    st.job_seconds += job_seconds > 0
                          ? job_seconds
                          : now - (s->dispatched_at.count(node) ? s->dispatched_at[node] : now);
    st.last_done = now;
    if (n.stage == Stage::kFusion) FeedSurface(s, n.instant, n.part, outs.at(0), std::move(slab));
    if (n.stage == Stage::kSurface) {
      // The slabs are in the mesh now; the journal's surface record stands for them
      // once it is on disk.
      s->journal->Sync();
      for (int k = 0; k < s->num_slabs; ++k) {
        const int f =
            s->graph->Find(s->graph->instants()[n.instant] + "/fusion/" + std::to_string(k));
        for (const auto& b : s->outputs[f]) blobs.Drop(b.sha256());
        s->outputs[f].clear();
      }
    }
    if (s->graph->InstantDone(n.instant)) {
      s->instant_stats[n.instant].done = now;
      spdlog::info("session {}: instant {} done ({:.2f} s)", s->id, s->graph->instants()[n.instant],
                   now - s->instant_stats[n.instant].first_start);
    }
    Publish(*s, n.instant, n.stage, "");
    Advance(s);
  }

  // Checks a finished job's outputs and writes what they make in OUT and the blob
  // store; throws core::InputError on bad outputs. Runs beside the loop (Offload): it
  // reads only what a session fixes at its submit, and the thread-safe blob store.
  // A fusion result's slab, decoded to check it, goes to `slab` for the surface stream.
  std::vector<runtime::BlobRef> StoreOutputs(const SessionRec& session, const JobNode& n,
                                             const runtime::JobResult& r, const std::string& peer,
                                             std::shared_ptr<const fusion::Slab>* slab) {
    const SessionRec* s = &session;
    const std::string& instant = s->graph->instants()[n.instant];
    const fs::path dir = s->out() / instant;
    auto find = [&](const std::string& name) -> const std::string& {
      for (const auto& o : r.outputs()) {
        if (o.name() == name) return o.data();
      }
      throw core::InputError(peer, "result of " + r.job_id() + " lacks output '" + name + "'");
    };
    std::vector<runtime::BlobRef> outs;
    switch (n.stage) {
      case Stage::kStereo: {
        const std::string& bytes = find(pipeline::kStereoOutput);
        stereo::StereoResult result = pipeline::DecodeStereoOutput(bytes, peer + " " + r.job_id());
        core::Require(result.camera == s->cameras[n.part], peer,
                      "result of " + r.job_id() + " is for camera '" + result.camera + "'");
        // The worker encoded the files; checking them costs a fraction of encoding.
        std::vector<stereo::StereoFile> files;
        for (const auto& o : r.outputs()) {
          if (o.name() != pipeline::kStereoOutput) files.push_back({o.name(), o.data()});
        }
        stereo::CheckStereoFiles(result, s->options.stereo.write_previews, files,
                                 peer + " result of " + r.job_id());
        stereo::WriteStereoFiles(files, instant, s->out());
        outs.push_back(blobs.AddBytes(s->blob_dir(), bytes, pipeline::kStereoOutput));
        break;
      }
      case Stage::kFusion: {
        const std::string& bytes = find(pipeline::kSlabOutput);
        auto decoded = std::make_shared<const fusion::Slab>(
            fusion::DecodeSlab(bytes, peer + " " + r.job_id()));
        core::Require(decoded->k0 == n.part * s->options.slab_planes &&
                          decoded->nx == s->options.grid.nx && decoded->ny == s->options.grid.ny,
                      peer, "result of " + r.job_id() + " is not the slab asked for");
        *slab = std::move(decoded);
        outs.push_back(blobs.AddBytes(s->blob_dir(), bytes, pipeline::kSlabOutput));
        break;
      }
      case Stage::kDecimate: {
        const std::string& bytes = find(pipeline::kDecimatedOutput);
        io::ParsePly(bytes, peer + " " + r.job_id());
        outs.push_back(blobs.AddBytes(s->blob_dir(), bytes, pipeline::kDecimatedOutput));
        break;
      }
      case Stage::kTexture: {
        fs::create_directories(dir);
        const std::string& ply = find(pipeline::kDecimatedOutput);
        io::ParsePly(ply, peer + " " + r.job_id());
        std::vector<std::string> names = {pipeline::kDecimatedOutput};
        if (s->options.texture) {
          for (const char* name : {pipeline::kTexturedObj, pipeline::kTexturedMtl,
                                   pipeline::kTexturedPng, pipeline::kTexturedGlb}) {
            names.push_back(name);
          }
        }
        for (const std::string& name : names) {
          const std::string& bytes = find(name);
          io::WriteFileAtomically(dir / name, bytes);
          outs.push_back(blobs.AddBytes(s->blob_dir(), bytes, name));
        }
        break;
      }
      case Stage::kNoop:
        break;
      case Stage::kSurface:
        throw core::InputError(peer, "sent a result for the master's own stage " + r.job_id());
    }
    return outs;
  }

  void Fail(SessionRec* s, const std::string& error) {
    if (s->state != "running") return;
    s->state = "failed";
    s->error = error;
    s->finished_s = s->Now();
    spdlog::error("session {} failed: {}", s->id, error);
    DropQueued(s);
    AbortSurfaces(s);
    Publish(*s, -1, Stage::kStereo, error);
  }

  void DropQueued(SessionRec* s) {
    for (auto& [node, worker] : s->running_on) {
      auto it = workers.find(worker);
      if (it != workers.end()) it->second.Forget(s->id + "/" + s->graph->node(node).key);
    }
    s->running_on.clear();
  }

  void Finish(SessionRec* s) {
    s->state = "done";
    s->finished_s = s->Now();
    s->journal->Sync();
    WriteReport(*s);
    spdlog::info(
        "session {} done in {:.2f} s ({} jobs, {} re-queued, {} duplicate results dropped)", s->id,
        s->finished_s, s->graph->size(), s->requeued, s->duplicates);
    Publish(*s, -1, Stage::kStereo, "done");
  }

  void WriteReport(const SessionRec& s) {
    double worker_job_seconds = 0;  // the master's own surface stage is not a worker's
    for (int k = 0; k < kNumStages; ++k) {
      if (Stage(k) != Stage::kSurface) worker_job_seconds += s.stage_stats[k].job_seconds;
    }
    const double loop_busy = loop_busy_s - s.loop_busy_at_start;
    std::string j =
        "{\n  \"session\": \"" + s.id + "\",\n  \"take\": \"" + s.spec.take() +
        "\",\n  \"cameras\": " + std::to_string(s.cameras.size()) +
        ",\n  \"instants\": " + std::to_string(s.graph->instants().size()) +
        ",\n  \"slabs_per_instant\": " + std::to_string(s.num_slabs) +
        ",\n  \"jobs\": " + std::to_string(s.graph->size()) +
        ",\n  \"jobs_resumed_from_journal\": " + std::to_string(s.resumed) +
        ",\n  \"jobs_requeued\": " + std::to_string(s.requeued) +
        ",\n  \"duplicate_results_dropped\": " + std::to_string(s.duplicates) +
        ",\n  \"bytes_to_workers\": " + std::to_string(s.bytes_to_workers) +
        ",\n  \"bytes_from_workers\": " + std::to_string(s.bytes_from_workers) +
        ",\n  \"seconds\": " + Num(s.finished_s) +
        ",\n  \"seconds_per_instant\": " + Num(s.finished_s / double(s.graph->instants().size())) +
        ",\n  \"worker_job_seconds\": " + Num(worker_job_seconds) +
        ",\n  \"master_loop\": {\"busy_fraction\": " +
        Num(s.finished_s > 0 ? loop_busy / s.finished_s : 0) +
        ", \"longest_turn_s\": " + Num(s.loop_longest_turn_s) + "}" + ",\n  \"stages\": {";
    bool first = true;
    for (int k = 0; k < kNumStages; ++k) {
      int total = 0;
      for (int t = 0; t < int(s.graph->instants().size()); ++t)
        total += s.graph->Count(t, Stage(k)).total;
      if (total == 0) continue;
      const auto& st = s.stage_stats[k];
      j += std::string(first ? "" : ",") + "\n    \"" + StageName(Stage(k)) +
           "\": {\"jobs\": " + std::to_string(total) + ", \"job_seconds\": " + Num(st.job_seconds) +
           ", \"wall_seconds\": " +
           Num(st.last_done >= 0 && st.first_start >= 0 ? st.last_done - st.first_start : 0) +
           ", \"bytes_to_workers\": " + std::to_string(st.bytes_to_workers) +
           ", \"bytes_from_workers\": " + std::to_string(st.bytes_from_workers) + "}";
      first = false;
    }
    j += "\n  },\n  \"jobs_by_worker\": {";
    first = true;
    for (const auto& [name, count] : s.jobs_by_worker) {
      std::string quoted;
      for (const char c : name) {
        if (c == '"' || c == '\\') quoted += '\\';
        if (static_cast<unsigned char>(c) >= 0x20) quoted += c;
      }
      j += std::string(first ? "" : ",") + "\n    \"" + quoted + "\": " + std::to_string(count);
      first = false;
    }
    j += "\n  },\n  \"per_instant\": [";
    for (int t = 0; t < int(s.graph->instants().size()); ++t) {
      const auto& is = s.instant_stats[t];
      j += std::string(t ? "," : "") + "\n    {\"instant\": \"" + s.graph->instants()[t] +
           "\", \"seconds\": " +
           Num(is.done >= 0 && is.first_start >= 0 ? is.done - is.first_start : 0) +
           ", \"done_at_seconds\": " + Num(is.done) + "}";
    }
    j += "\n  ]\n}\n";
    io::WriteFileAtomically(s.out() / "report.json", j);
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
    for (const std::string& job : jobs) Requeue(id, name, why, job);
  }

  // A job sent to a worker now lost goes back to the ready set.
  void Requeue(const std::string& id, const std::string& name, const std::string& why,
               const std::string& job) {
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
    const int losses = ++s->losses[node];
    spdlog::warn("{} lost ({}); re-queued job {} (lost {} time{})", name, why, job, losses,
                 losses == 1 ? "" : "s");
    if (losses >= options.max_job_losses) {
      Fail(s, "job " + job + " was lost with " + std::to_string(losses) + " workers");
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
      if (net::IsSha256Hex(sha)) bytes = blobs.Read(sha);
      if (!bytes) {
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
            s->stage_stats[int(s->graph->node(found->second).stage)].bytes_to_workers +=
                int64_t(b->data().size());
          }
        }
      }
      SendToWorker(id, env);
    }
  }

  void OnResult(const std::string& id, runtime::JobResult r) {
    const std::string peer = WorkerName(id);
    auto w = workers.find(id);
    if (w != workers.end()) w->second.Forget(r.job_id());
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
    if (s->state != "running") {
      spdlog::info("{}: result for {} of {} session {} dropped", peer, r.job_id(), s->state, s->id);
      return;
    }
    if (n.state == JobState::kDone) {
      ++s->duplicates;
      spdlog::info("{}: late or duplicate result for {} dropped", peer, r.job_id());
      return;
    }
    if (n.stage == Stage::kSurface || n.state == JobState::kWaiting) {
      throw core::InputError(peer, "result for " + r.job_id() + ", which was never dispatched");
    }
    if (!r.ok()) {
      // Jobs are deterministic: an input error on one worker is one on every worker.
      Fail(s, "job " + r.job_id() + " failed on " + peer + ": " + r.error());
      return;
    }
    // Checking, hashing and writing the outputs happens beside the loop; the worker is
    // free for its next job meanwhile. Accepted() takes it from there.
    const std::string name = w != workers.end() ? w->second.name : net::PeerName(id);
    auto result = std::make_shared<runtime::JobResult>(std::move(r));
    JobNode job = n;  // what the work may read: the loop goes on changing the graph
    job.dependents.clear();
    offload.Post([this, s, node, id, peer, name, result, job]() -> std::function<void()> {
      try {
        std::shared_ptr<const fusion::Slab> slab;
        auto outs = std::make_shared<std::vector<runtime::BlobRef>>(
            StoreOutputs(*s, job, *result, peer, &slab));
        return [this, s, node, id, name, result, outs, slab] {
          Accepted(s, node, id, name, *result, *outs, slab);
        };
      } catch (const core::InputError& e) {
        return [this, s, node, id, peer, result, what = std::string(e.what())] {
          spdlog::warn("{}: bad result for {}: {}", peer, result->job_id(), what);
          const JobNode& n = s->graph->node(node);
          if (s->state == "running" && n.state == JobState::kRunning && s->running_on.count(node) &&
              s->running_on[node] == id) {
            s->running_on.erase(node);
            s->graph->Requeue(node);
            ++s->requeued;
            spdlog::warn("re-queued job {} after a bad result", result->job_id());
          }
        };
      }
    });
  }

  // A result whose outputs are stored (on the loop's thread again).
  void Accepted(SessionRec* s, int node, const std::string& id, const std::string& name,
                const runtime::JobResult& r, const std::vector<runtime::BlobRef>& outs,
                std::shared_ptr<const fusion::Slab> slab) {
    const JobNode& n = s->graph->node(node);
    if (s->state != "running") return;
    if (n.state == JobState::kDone) {
      // Another worker's result for the same job was stored first.
      ++s->duplicates;
      spdlog::info("late or duplicate result for {} dropped", r.job_id());
      return;
    }
    // Every output received (a stereo result's files too, which are written, not stored).
    for (const auto& o : r.outputs()) {
      s->bytes_from_workers += int64_t(o.data().size());
      s->stage_stats[int(n.stage)].bytes_from_workers += int64_t(o.data().size());
    }
    if (n.state == JobState::kReady) {
      // Requeued after its worker was lost, and now the result came after all.
      s->graph->MarkRunning(node);
    } else if (s->running_on.count(node) && s->running_on[node] != id) {
      auto other = workers.find(s->running_on[node]);
      if (other != workers.end()) other->second.Forget(r.job_id());
    }
    ++s->jobs_by_worker[name];
    Completed(s, node, outs, r.seconds(), std::move(slab));
  }

  // Idle workers first get the highest-priority ready jobs; then, while ready jobs are
  // left over, busy workers get up to options.jobs_ahead more of the stages that come
  // many to an instant (stereo, fusion), which they fetch the inputs of while they
  // compute and start the moment their job ends. The long one-per-instant stages are
  // never sent ahead: one waiting behind another job could keep an idle worker idle.
  void Dispatch() {
    for (int ahead = 0; ahead <= options.jobs_ahead; ++ahead) {
      for (auto& [id, w] : workers) {
        if (int(w.jobs.size()) != ahead) continue;
        SessionRec* best = nullptr;
        int node = -1;
        if (!NextJob(ahead > 0, &best, &node)) return;
        runtime::Job job = MakeJob(best, node, w);
        best->graph->MarkRunning(node);
        best->running_on[node] = id;
        Touch(best, node);
        w.jobs.push_back(job.id());
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
      if (s->state != "running") continue;
      for (int n : s->graph->ready()) {
        const Stage stage = s->graph->node(n).stage;
        if (stage == Stage::kSurface) continue;
        if (ahead && !(stage == Stage::kStereo || stage == Stage::kFusion || stage == Stage::kNoop))
          return false;
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
    st.set_state(s.state);
    st.set_take(s.spec.take());
    st.set_out(s.spec.out());
    st.set_error(s.error);
    st.set_elapsed_s(s.finished_s >= 0 ? s.finished_s : s.Now());
    st.set_workers(int(workers.size()));
    if (!s.graph) return st;
    st.set_jobs_done(s.graph->done());
    st.set_jobs_total(s.graph->size());
    for (int t = 0; t < int(s.graph->instants().size()); ++t) {
      auto* is = st.add_instants();
      is->set_instant(s.graph->instants()[t]);
      is->set_done(s.graph->InstantDone(t));
      for (int k = 0; k < kNumStages; ++k) {
        const StageCount c = s.graph->Count(t, Stage(k));
        if (c.total == 0) continue;
        auto* sp = is->add_stages();
        sp->set_stage(StageName(Stage(k)));
        sp->set_done(c.done);
        sp->set_total(c.total);
      }
    }
    return st;
  }

  runtime::ControlReply OnControl(const runtime::ControlRequest& req) {
    runtime::ControlReply reply;
    reply.set_ok(true);
    try {
      switch (req.kind_case()) {
        case runtime::ControlRequest::kSubmit:
          reply.set_session_id(Submit(req.submit().session()));
          *reply.add_sessions() = Status(*sessions[reply.session_id()]);
          break;
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
          if (req.has_cancel() && it->second->state == "running") {
            it->second->state = "cancelled";
            it->second->finished_s = it->second->Now();
            DropQueued(it->second.get());
            AbortSurfaces(it->second.get());
            spdlog::info("session {} cancelled", id);
            Publish(*it->second, -1, Stage::kStereo, "cancelled");
          }
          reply.set_session_id(id);
          *reply.add_sessions() = Status(*it->second);
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
        spdlog::warn("{}: refused a message of {} frames on the worker socket (expected 1)",
                     net::PeerName(id), frames.size() - 1);
        Refuse(&workers_socket, id, "expected one frame per message", false);
        continue;
      }
      try {
        runtime::Envelope env = net::DecodeEnvelope(frames[1].to_string_view(), WorkerName(id),
                                                    options.socket.max_message_bytes);
        OnWorkerMessage(id, env);
      } catch (const core::InputError& e) {
        spdlog::warn("refused on the worker socket: {}", e.what());
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
        spdlog::warn("{}: refused a message of {} frames on the control socket", peer,
                     frames.size() - 1);
        Refuse(&control_socket, id, "expected [empty, request] frames", frames.size() >= 3);
        continue;
      }
      runtime::ControlReply reply;
      try {
        const runtime::Envelope env = net::DecodeEnvelope(frames.back().to_string_view(), peer,
                                                          options.socket.max_message_bytes);
        core::Require(env.has_control(), peer, "sent a message that is not a control request");
        reply = OnControl(env.control());
      } catch (const core::InputError& e) {
        spdlog::warn("refused on the control socket: {}", e.what());
        Refuse(&control_socket, id, e.what(), req);
        continue;
      }
      runtime::Envelope env;
      *env.mutable_control_reply() = reply;
      const std::string bytes = net::EncodeEnvelope(env);
      if (req) {
        net::SendFrames(&control_socket, {id, "", bytes});
      } else {
        net::SendFrames(&control_socket, {id, bytes});
      }
    }
  }

  void Run(const std::atomic<bool>* stop) {
    const int interval = options.heartbeat_interval_ms;
    while (!stop->load()) {
      zmq::pollitem_t items[] = {
          {workers_socket.handle(), 0, ZMQ_POLLIN, 0},
          {control_socket.handle(), 0, ZMQ_POLLIN, 0},
          {capture_ingest ? capture_ingest->socket().handle() : nullptr, 0, ZMQ_POLLIN, 0}};
      // Back soon while work beside the loop is out, so that its outcome is acted on.
      const int wait_ms = offload.pending() > 0 ? 1 : std::min(interval, 20);
      try {
        zmq::poll(items, capture_ingest ? 3 : 2, std::chrono::milliseconds(wait_ms));
      } catch (const zmq::error_t& e) {
        if (e.num() != EINTR) throw;
        continue;  // a signal; *stop says whether to go on
      }
      const auto turn_start = Clock::now();
      if (items[0].revents & ZMQ_POLLIN) HandleWorkerSocket();
      if (items[1].revents & ZMQ_POLLIN) HandleControlSocket();
      if (capture_ingest && (items[2].revents & ZMQ_POLLIN)) capture_ingest->Poll(0);
      offload.Collect();
      PollSurfaces();
      const auto now = Clock::now();
      std::vector<std::string> expired;
      for (const auto& [id, w] : workers) {
        if (now > w.expiry) expired.push_back(id);
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
      }
      Dispatch();
      if (Clock::now() >= next_journal_sync) {
        SyncJournals();
        next_journal_sync = Clock::now() + kJournalSyncInterval;
      }
      const double turn = Seconds(Clock::now() - turn_start);
      loop_busy_s += turn;
      for (auto& [id, s] : sessions) {
        if (s->state == "running") s->loop_longest_turn_s = std::max(s->loop_longest_turn_s, turn);
      }
    }
    SyncJournals();
    StopSurfaces();
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

  // Stops every surface stream before the blob store they read goes away.
  void StopSurfaces() {
    for (auto& [id, s] : sessions) {
      AbortSurfaces(s.get());
      s->surface.clear();
    }
  }

  ~Impl() { StopSurfaces(); }
};

Master::Master(zmq::context_t* context, const MasterOptions& options)
    : impl_(std::make_unique<Impl>(context, options)) {}
Master::~Master() = default;
const MasterEndpoints& Master::endpoints() const { return impl_->endpoints; }
void Master::Run(const std::atomic<bool>* stop) { impl_->Run(stop); }

}  // namespace dome::scheduler
