#include "worker/worker.h"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <deque>
#include <future>
#include <map>
#include <optional>
#include <set>
#include <thread>
#include <vector>

#include "core/error.h"
#include "core/parallel_for.h"
#include "core/timer.h"
#include "core/wake_pipe.h"
#include "net/blob_cache.h"
#include "net/content_hash.h"
#include "net/security.h"
#include "pipeline/shared_hulls.h"

namespace dome::worker {
using Clock = std::chrono::steady_clock;

void WorkerOptions::Check() const {
  core::Require(!master.empty(), "--master", "names no master endpoint");
  core::Require(
      cache_mb >= 1, "--cache-mb",
      "must be at least 1 MiB (it holds a job's inputs at once), got " + std::to_string(cache_mb));
  core::Require(heartbeat_interval_ms > 0, "--heartbeat-ms", "must be positive");
  core::Require(heartbeat_liveness > 0, "--liveness", "must be positive");
  core::Require(reconnect_max_ms >= heartbeat_interval_ms, "--reconnect-max-ms",
                "must be at least the heartbeat interval");
  core::Require(stages != nullptr, "stages", "names no stage set");
  socket.Check();
}

// Replies for one blob that do not hash to its address before the jobs needing it are
// failed (count).
constexpr int kMaxCorruptReplies = 3;
// What a BlobReply adds to the blob it carries (proto/runtime.proto: the envelope's
// version and field tags, the 64-character address, varint lengths): about 90 bytes;
// rounded up.
constexpr int64_t kBlobReplyFramingBytes = 256;

struct Worker::Impl {
  zmq::context_t* context;
  WorkerOptions options;
  std::unique_ptr<zmq::socket_t> socket;
  std::unique_ptr<net::HandshakeLog> handshake_log;  // after the socket: destroyed first
  net::BlobCache cache;
  WorkerStats stats;
  std::deque<runtime::Job> queue;      // jobs received, not started
  std::set<std::string> requested;     // blobs asked for, not yet received
  std::map<std::string, int> corrupt;  // blob -> replies that did not hash to its address
  std::string running_id;              // the job on the job thread; "" when none
  // The largest result the master takes for that job, bytes: the smaller of its cap
  // (Job.max_result_bytes) and this worker's own.
  int64_t running_cap = 0;
  pipeline::JobMemo memo;              // used by the running job only; outlives it
  std::optional<pipeline::WorkerThreads> counted;  // this worker's threads, for the process
  std::future<runtime::JobResult> running;
  Clock::time_point master_expiry, next_heartbeat;
  int backoff_ms;
  bool in_process = false;  // the master's endpoint is inproc: its replies are not re-hashed
  // Woken by the job thread as its job ends, polled beside the master's socket: the
  // result goes out at once instead of when the poll times out (10 ms, half of it on
  // average, at every job: about 0.1 s over a Robovision instant's 35 jobs).
  core::WakePipe job_done{"worker"};

  Impl(zmq::context_t* ctx, const WorkerOptions& o)
      : context(ctx), options(o), cache(o.cache_mb << 20), backoff_ms(o.heartbeat_interval_ms) {
    options.Check();
    in_process = options.master.rfind("inproc://", 0) == 0;
    if (options.threads <= 0) options.threads = core::HardwareThreads();
    counted.emplace(options.threads);
    if (options.name.empty()) {
      char host[256] = {0};
      gethostname(host, sizeof host - 1);
      options.name = std::string(host) + ":" + std::to_string(::getpid());
    }
  }

  ~Impl() {
    if (running.valid()) running.wait();  // the job thread wakes job_done
  }

  void Send(const runtime::Envelope& env) {
    const std::string bytes = net::EncodeEnvelope(env);
    net::SendFrames(socket.get(), {bytes});
  }

  void Connect() {
    handshake_log.reset();  // before the socket it watches goes
    socket = std::make_unique<zmq::socket_t>(*context, zmq::socket_type::dealer);
    net::ConfigureSocket(socket.get(), options.socket);
    if (options.socket.curve_client()) {
      // A master that refuses this worker's key answers nothing: say why in the log.
      handshake_log = std::make_unique<net::HandshakeLog>(
          context, std::vector<std::pair<zmq::socket_t*, std::string>>{{socket.get(), "worker"}},
          true);
    }
    socket->connect(options.master);
    requested.clear();
    runtime::Envelope env;
    auto* h = env.mutable_hello();
    h->set_name(options.name);
    h->set_threads(options.threads);
    h->set_cache_mb(options.cache_mb);
    Send(env);
    master_expiry = Clock::now() + Liveness();
    next_heartbeat = Clock::now() + std::chrono::milliseconds(options.heartbeat_interval_ms);
  }

  std::chrono::milliseconds Liveness() const {
    return std::chrono::milliseconds(options.heartbeat_interval_ms * options.heartbeat_liveness);
  }

  // Asks for the missing blobs of the next queued job, also while a job runs (a job
  // sent ahead then finds its inputs here when the running one ends); starts it when
  // nothing runs and all its blobs are here. Only the next one: a small cache holding
  // the inputs of one job is never asked to hold two.
  void MaybeStart() {
    if (queue.empty()) return;
    const runtime::Job& job = queue.front();
    int64_t bytes = 0;
    for (const auto& b : job.blobs()) bytes += int64_t(b.size());
    if (bytes > (options.cache_mb << 20)) {
      // The master sends such a job only to a worker that said its cache is larger.
      FailQueued(job.id(), "its inputs (" + std::to_string(bytes >> 20) +
                               " MiB) do not fit in this worker's --cache-mb " +
                               std::to_string(options.cache_mb));
      return;
    }
    for (const auto& b : job.blobs()) {
      // Each blob comes in a reply of its own. One over this worker's cap would be
      // refused (over twice the cap, dropped unread with the connection) and asked for
      // again without end: the job fails naming the input and the cap.
      if (int64_t(b.size()) + kBlobReplyFramingBytes > options.socket.max_message_bytes) {
        FailQueued(job.id(), "its input " + b.name() + " is " + std::to_string(b.size()) +
                                 " bytes, over this worker's message cap of " +
                                 std::to_string(options.socket.max_message_bytes) +
                                 " bytes with its reply's framing (--max-message-bytes, on "
                                 "the master and its workers alike)");
        return;
      }
    }
    for (const auto& b : job.blobs()) {
      const std::string& sha = b.sha256();
      if (requested.count(sha) != 0 || cache.Get(sha)) continue;
      // One blob per request: replies stay under the message cap, and they pipeline.
      runtime::Envelope env;
      env.mutable_blob_request()->add_sha256(sha);
      Send(env);
      requested.insert(sha);
    }
    if (running.valid()) return;
    for (const auto& b : job.blobs()) {
      if (requested.count(b.sha256()) != 0) return;  // on its way
    }
    pipeline::JobBlobs held;
    for (const auto& b : job.blobs()) {
      auto bytes = cache.Get(b.sha256());
      if (!bytes) return;  // evicted meanwhile (cache too small): asked again next turn
      held.push_back(bytes);
    }
    runtime::Job j = std::move(queue.front());
    queue.pop_front();
    counted->SetIdle(false);  // before counting the others' idle threads
    if (const int s = options.stages->Find(j.stage());
        s >= 0 && options.stages->stages[size_t(s)].borrows_idle_threads) {
      j.set_threads(pipeline::LentThreads(j.threads()));
    }
    running_id = j.id();
    running_cap = j.max_result_bytes() > 0
                      ? std::min(j.max_result_bytes(), options.socket.max_message_bytes)
                      : options.socket.max_message_bytes;
    running = std::async(std::launch::async, [this, j = std::move(j), held = std::move(held)]() {
      runtime::JobResult result;
      result.set_job_id(j.id());
      core::Stopwatch watch;
      try {
        for (auto& o : pipeline::RunJob(*options.stages, j, held, &memo)) {
          *result.add_outputs() = std::move(o);
        }
        result.set_ok(true);
      } catch (const std::exception& e) {
        result.set_ok(false);
        result.set_error(e.what());
        result.clear_outputs();
      }
      result.set_seconds(watch.ElapsedSeconds());
      job_done.Wake();  // the loop, woken, waits the moment left until the result is ready
      return result;
    });
  }

  // Answers a queued job it cannot run with a failed result, so that nothing waits for
  // it; the master fails its session with `why`.
  void FailQueued(std::string job_id, const std::string& why) {  // a copy: it may be in the queue
    for (auto it = queue.begin(); it != queue.end(); ++it) {
      if (it->id() != job_id) continue;
      queue.erase(it);
      runtime::Envelope env;
      env.mutable_result()->set_job_id(job_id);
      env.mutable_result()->set_ok(false);
      env.mutable_result()->set_error(why);
      spdlog::warn("job {} not run: {}", job_id, why);
      ++stats.failed_jobs;
      Send(env);
      return;
    }
  }

  // Fails every queued job that needs blob `sha`.
  void FailJobsNeeding(const std::string& sha, const std::string& why) {
    std::vector<std::string> ids;
    for (const auto& j : queue) {
      for (const auto& r : j.blobs()) {
        if (r.sha256() == sha) {
          ids.push_back(j.id());
          break;
        }
      }
    }
    for (const auto& id : ids) FailQueued(id, why);
  }

  void OnMessage(runtime::Envelope env) {  // by value: blob bytes move into the cache
    switch (env.body_case()) {
      case runtime::Envelope::kHeartbeat:
        break;
      case runtime::Envelope::kDropJob: {
        const auto& d = env.drop_job();
        const auto before = queue.size();
        queue.erase(std::remove_if(queue.begin(), queue.end(),
                                   [&](const runtime::Job& j) { return j.id() == d.job_id(); }),
                    queue.end());
        if (queue.size() != before) {
          spdlog::info("master: dropped job {}: {}", d.job_id(), d.reason());
        } else if (d.job_id() == running_id) {
          spdlog::warn("master: dropped job {} while it runs ({}); its result will be late",
                       d.job_id(), d.reason());
        }
        break;
      }
      case runtime::Envelope::kJob:
        spdlog::debug("job {}", env.job().id());
        queue.push_back(env.job());
        break;
      case runtime::Envelope::kBlobReply:
        for (auto& b : *env.mutable_blob_reply()->mutable_blobs()) {
          requested.erase(b.sha256());
          if (b.missing()) {
            FailJobsNeeding(b.sha256(), "the master has no blob " + b.sha256().substr(0, 12) +
                                            "... (its file is gone or changed)");
            continue;
          }
          // A reply over inproc (an embedded worker of `dome run`) never left the process:
          // the bytes are those the master's store checked, and hashing them again cost
          // each worker as much again (Robovision's fusion inputs, 63 MB, on both workers).
          if (!in_process && net::Sha256Hex(b.data()) != b.sha256()) {
            // Asked again (MaybeStart) a few times: a reply damaged on its way is rare.
            if (++corrupt[b.sha256()] >= kMaxCorruptReplies) {
              FailJobsNeeding(b.sha256(), "the master sent blob " + b.sha256().substr(0, 12) +
                                              "... " + std::to_string(kMaxCorruptReplies) +
                                              " times with bytes that do not hash to its address");
              corrupt.erase(b.sha256());
            } else {
              spdlog::warn("master: blob {} does not hash to its address; asking again",
                           b.sha256());
            }
            continue;
          }
          corrupt.erase(b.sha256());
          ++stats.blobs_fetched;
          stats.bytes_fetched += int64_t(b.data().size());
          cache.Put(b.sha256(), std::make_shared<const std::string>(std::move(*b.mutable_data())));
        }
        break;
      case runtime::Envelope::kDisconnect:
        spdlog::info("master: {}", env.disconnect().reason());
        Reconnect(false);
        break;
      case runtime::Envelope::kRefusal:
        spdlog::warn("master refused a message: {}", env.refusal().reason());
        break;
      default:
        spdlog::warn("master: unexpected message ignored");
    }
  }

  void Reconnect(bool back_off, const std::atomic<bool>* stop = nullptr) {
    ++stats.reconnects;
    if (back_off) {
      spdlog::warn("master silent for {} ms; reconnecting in {} ms", Liveness().count(),
                   backoff_ms);
      // Sleep in short steps so SIGTERM stops a worker whose master is gone at once.
      const auto until = Clock::now() + std::chrono::milliseconds(backoff_ms);
      while (Clock::now() < until && !(stop && stop->load())) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
      backoff_ms = std::min(2 * backoff_ms, options.reconnect_max_ms);
      if (stop && stop->load()) return;
    }
    // Jobs not started belong to the old connection: the master re-queues them.
    queue.clear();
    Connect();
  }

  void Run(const std::atomic<bool>* stop) {
    Connect();
    while (!stop->load()) {
      // A signal cuts the wait short; *stop then says whether to go on.
      zmq::pollitem_t items[] = {{socket->handle(), 0, ZMQ_POLLIN, 0},
                                 {nullptr, job_done.read_fd(), ZMQ_POLLIN, 0}};
      try {
        zmq::poll(items, 2, std::chrono::milliseconds(10));
      } catch (const zmq::error_t& e) {
        if (e.num() != EINTR) throw;
        items[0].revents = items[1].revents = 0;
      }
      if (items[1].revents & ZMQ_POLLIN) {
        job_done.Drain();
        // The job that woke it returns in a moment. A wake left over from a job already
        // answered (its result went out on a turn the socket woke) must not hold the
        // loop for the next job's whole run: the wait is bounded like the poll.
        if (running.valid()) running.wait_for(std::chrono::milliseconds(10));
      }
      if (items[0].revents & ZMQ_POLLIN) {
        for (int budget = 0; budget < 1000; ++budget) {
          const std::vector<zmq::message_t> frames = net::ReceiveFrames(socket.get());
          if (frames.empty()) break;
          if (frames.size() != 1) {
            spdlog::warn("master: multipart message ignored");  // the master sends one frame
            continue;
          }
          master_expiry = Clock::now() + Liveness();
          backoff_ms = options.heartbeat_interval_ms;
          try {
            OnMessage(net::DecodeEnvelope(frames[0].to_string_view(), "master " + options.master,
                                          options.socket.max_message_bytes));
          } catch (const core::InputError& e) {
            spdlog::warn("refused: {}", e.what());
          }
        }
      }
      if (running.valid() &&
          running.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
        runtime::Envelope env;
        *env.mutable_result() = running.get();
        running_id.clear();
        const size_t bytes = env.ByteSizeLong();
        if (int64_t(bytes) > running_cap) {
          // The master would refuse it (or its socket drop it unread with the
          // connection, when over twice its cap) and take this worker for lost, again
          // and again: say what happened instead.
          const std::string id = env.result().job_id();
          env.mutable_result()->Clear();
          env.mutable_result()->set_job_id(id);
          env.mutable_result()->set_ok(false);
          env.mutable_result()->set_error(
              "its result is " + std::to_string(bytes) + " bytes, over the message cap of " +
              std::to_string(running_cap) +
              " bytes (--max-message-bytes, on the master and its workers alike)");
        }
        ++stats.jobs;
        if (!env.result().ok()) {
          ++stats.failed_jobs;
          spdlog::warn("job {} failed: {}", env.result().job_id(), env.result().error());
        }
        Send(env);
      }
      MaybeStart();
      counted->SetIdle(!running.valid() && queue.empty());
      const auto now = Clock::now();
      if (now >= next_heartbeat) {
        runtime::Envelope hb;
        hb.mutable_heartbeat();
        Send(hb);
        next_heartbeat = now + std::chrono::milliseconds(options.heartbeat_interval_ms);
      }
      if (now > master_expiry) Reconnect(true, stop);
    }
    if (running.valid()) running.wait();
    runtime::Envelope bye;
    bye.mutable_disconnect()->set_reason("worker stopping");
    Send(bye);
  }
};

Worker::Worker(zmq::context_t* context, const WorkerOptions& options)
    : impl_(std::make_unique<Impl>(context, options)) {}
Worker::~Worker() = default;
void Worker::Run(const std::atomic<bool>* stop) { impl_->Run(stop); }
WorkerStats Worker::stats() const { return impl_->stats; }

}  // namespace dome::worker
