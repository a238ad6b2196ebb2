#include "cli/client.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <thread>
#include <vector>

#include "core/error.h"
#include "core/json.h"
#include "core/parallel_for.h"
#include "io/file_util.h"
#include "net/events.h"
#include "net/wire.h"
#include "take/take.h"
#include "worker/worker.h"

namespace dome::client {
using Clock = std::chrono::steady_clock;

runtime::ControlReply Request(zmq::context_t* context, const std::string& endpoint,
                              const runtime::ControlRequest& request, int timeout_ms,
                              const net::SocketOptions& options) {
  // The embedded master's in-process endpoint means nothing to a user.
  const std::string where =
      endpoint.rfind("inproc://", 0) == 0 ? std::string("master") : "master " + endpoint;
  zmq::socket_t socket(*context, zmq::socket_type::req);
  net::ConfigureSocket(&socket, options);
  try {
    socket.connect(endpoint);
  } catch (const zmq::error_t& e) {
    throw core::InputError(where, std::string("cannot connect: ") + e.what());
  }
  runtime::Envelope env;
  *env.mutable_control() = request;
  const std::string bytes = net::EncodeEnvelope(env);
  // The send has the time limit too: the whole request never waits longer.
  const auto start = Clock::now();
  const bool sent = net::SendWithin(&socket, bytes, timeout_ms);
  const int left =
      timeout_ms -
      int(std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - start).count());
  zmq::message_t reply;
  if (!sent || !net::WaitForInput(&socket, std::max(left, 0)) ||
      !socket.recv(reply, zmq::recv_flags::dontwait)) {
    // A refused CURVE handshake looks the same from here: no answer.
    throw core::InputError(
        where, "no answer within " + std::to_string(timeout_ms) +
                   " ms (is dome-master running there" +
                   (options.curve_client() ? ", with this --master-key, and is the public key "
                                             "of --key on its allow-list?)"
                                           : "? a secure master ignores plaintext clients)"));
  }
  const runtime::Envelope answer =
      net::DecodeEnvelope(reply.to_string_view(), where, options.max_message_bytes);
  if (answer.has_refusal()) throw core::InputError(where, "refused: " + answer.refusal().reason());
  core::Require(answer.has_control_reply(), where, "answered with something else than a reply");
  if (!answer.control_reply().ok()) throw core::InputError(where, answer.control_reply().error());
  return answer.control_reply();
}

std::string EventsEndpointFor(const std::string& control) {
  const auto colon = control.rfind(':');
  if (colon == std::string::npos || control.compare(0, 6, "tcp://") != 0) return "";
  try {
    const int port = std::stoi(control.substr(colon + 1));
    return control.substr(0, colon + 1) + std::to_string(port + 1);
  } catch (const std::exception&) {
    return "";
  }
}

std::string FormatStatus(const runtime::SessionStatus& s) {
  char head[512];
  std::snprintf(head, sizeof head, "session %s  %s  %d/%d jobs  %.1f s  %d workers  out %s\n",
                s.id().c_str(), s.state().c_str(), s.jobs_done(), s.jobs_total(), s.elapsed_s(),
                s.workers(), s.out().c_str());
  std::string text = head;
  if (!s.error().empty()) text += "  error: " + s.error() + "\n";
  for (const auto& in : s.instants()) {
    text += "  " + in.instant() + (in.done() ? "  done " : "       ");
    for (const auto& st : in.stages()) {
      text +=
          "  " + st.stage() + " " + std::to_string(st.done()) + "/" + std::to_string(st.total());
    }
    text += "\n";
  }
  return text;
}

std::map<std::string, std::string> SessionOutputFiles(const std::filesystem::path& out) {
  namespace fs = std::filesystem;
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(out)) {
    if (!e.is_regular_file()) continue;
    const std::string rel = fs::relative(e.path(), out).string();
    if (rel.rfind(".blobs", 0) == 0 || rel.rfind("journal.log", 0) == 0 || rel == "report.json" ||
        rel == "session.json") {
      continue;
    }
    files[rel] = io::ReadFileBytes(e.path());
  }
  return files;
}

std::string EmptySurfaceWarning(const std::filesystem::path& out) {
  core::Json report;
  try {
    report = core::Json::parse(io::ReadFileBytes(out / "report.json"));
  } catch (const std::exception&) {
    return "";  // not here, or not a report: nothing to say about it
  }
  const core::Json empty = report.value("empty_surfaces", core::Json::object());
  const int count = empty.value("count", 0);
  if (count <= 0) return "";
  std::string names;
  for (const auto& i : empty.value("instants", core::Json::array())) {
    names += (names.empty() ? "" : ", ") + i.get<std::string>();
  }
  std::string box = "the session's volume";
  const core::Json v = report.value("volume", core::Json::object());
  const auto origin = v.value("origin_mm", std::vector<double>{});
  const auto dims = v.value("dims", std::vector<double>{});
  const double voxel = v.value("voxel_size_mm", 0.0);
  if (origin.size() == 3 && dims.size() == 3) {
    box = fmt::format("the volume [{:.0f} {:.0f} {:.0f}] .. [{:.0f} {:.0f} {:.0f}] mm", origin[0],
                      origin[1], origin[2], origin[0] + dims[0] * voxel,
                      origin[1] + dims[1] * voxel, origin[2] + dims[2] * voxel);
  }
  return fmt::format(
      "{} of {} instants ended with an empty surface ({}): no camera saw a surface inside {}; "
      "it may miss the scene (dome run --box)",
      count, report.value("instants", 0), names, box);
}

namespace {

// How long a watch keeps asking a master that stopped answering (restarting), s.
constexpr int kRestartPatienceS = 60;

runtime::SessionStatus QueryStatus(zmq::context_t* context, const std::string& control,
                                   const std::string& id, const net::SocketOptions& options) {
  runtime::ControlRequest req;
  req.mutable_status()->set_session_id(id);
  const runtime::ControlReply reply = Request(context, control, req, 10000, options);
  core::Require(reply.sessions_size() == 1, "master " + control, "status without the session");
  return reply.sessions(0);
}

}  // namespace

runtime::SessionStatus WaitForSession(zmq::context_t* context, const std::string& control,
                                      const std::string& events, const std::string& id,
                                      std::FILE* out, int poll_ms,
                                      const net::SocketOptions& options) {
  // Events are best-effort progress; the control socket stays the source of truth.
  std::unique_ptr<net::EventSubscription> sub;
  if (!events.empty()) sub = std::make_unique<net::EventSubscription>(context, events, options);
  const auto start = Clock::now();
  auto next_poll = start;
  int first_done = -1;
  // The master sends a subscriber events from when its subscription reaches it: an end
  // before that is never heard (a short session, a loaded machine). Until an event
  // shows the subscription is live the control socket is asked sooner, after 100 ms,
  // then twice as long each time up to poll_ms; from the first event every poll_ms.
  bool live = sub == nullptr;  // without events, the polls alone
  int early_ms = 100;
  // The master stopped answering then (Clock::time_point::max(): it answers).
  Clock::time_point silent_since = Clock::time_point::max();
  while (true) {
    if (Clock::now() >= next_poll) {
      runtime::SessionStatus st;
      try {
        st = QueryStatus(context, control, id, options);
        silent_since = Clock::time_point::max();
      } catch (const core::InputError& e) {
        // A master restarting (systemd brings it back in seconds; with --state it
        // resumes the session under its id): keep asking for a while, saying so once.
        const bool no_answer = std::string(e.what()).find("no answer within") != std::string::npos;
        if (!no_answer) throw;
        if (silent_since == Clock::time_point::max()) {
          silent_since = Clock::now();
          if (out != nullptr) {
            std::fprintf(out, "master %s not answering; asking again for up to %d s\n",
                         control.c_str(), kRestartPatienceS);
            std::fflush(out);
          }
        }
        if (Clock::now() - silent_since > std::chrono::seconds(kRestartPatienceS)) throw;
        next_poll = Clock::now() + std::chrono::milliseconds(poll_ms);
        continue;
      }
      if (st.state() != "running") return st;
      if (first_done < 0) first_done = st.jobs_done();
      next_poll =
          Clock::now() + std::chrono::milliseconds(live ? poll_ms : std::min(poll_ms, early_ms));
      early_ms = std::min(poll_ms, 2 * early_ms);
    }
    if (!sub) {
      std::this_thread::sleep_for(std::chrono::milliseconds(poll_ms));
      continue;
    }
    // The event of the session's end has the control socket asked at once, not at the
    // next poll (up to poll_ms later: the end of every `dome run` waited on it).
    bool ended = false;
    const auto until_poll =
        std::chrono::duration_cast<std::chrono::milliseconds>(next_poll - Clock::now()).count();
    sub->Drain(
        int(std::clamp<int64_t>(until_poll, 1, poll_ms)),
        [&](const runtime::StatusEvent& ev) {
          if (!live) {
            // From here the session's end is heard: the usual polls.
            live = true;
            next_poll = std::max(next_poll, Clock::now() + std::chrono::milliseconds(poll_ms));
          }
          if (out != nullptr && ev.has_capture()) {
            std::fprintf(out, "%s\n", FormatCaptureStatus(ev.capture()).c_str());
            std::fflush(out);
            return;
          }
          if (ev.session_id() == id && ev.stage().empty() &&
              (ev.state() == "done" || ev.state() == "failed" || ev.state() == "cancelled")) {
            ended = true;
          }
          if (ev.session_id() != id || out == nullptr) return;
          if (ev.stage().empty()) {
            // "submitted", or an error; the message of a state change repeats the state.
            const std::string message = ev.message() == ev.state() ? "" : " " + ev.message();
            std::fprintf(out, "[%7.1f s] session %s %s%s\n", ev.elapsed_s(), id.c_str(),
                         ev.state().c_str(), message.c_str());
            return;
          }
          // Rate over the jobs finished since we started watching; ETA from it.
          const double watched = std::chrono::duration<double>(Clock::now() - start).count();
          const int since = ev.jobs_done() - std::max(first_done, 0);
          const double rate = watched > 0 ? since / watched : 0;
          char eta[64] = "?";
          if (rate > 0)
            std::snprintf(eta, sizeof eta, "%.0f s", (ev.jobs_total() - ev.jobs_done()) / rate);
          const int width = 20;
          const int filled = ev.total() > 0 ? width * ev.done() / ev.total() : 0;
          std::fprintf(out, "[%7.1f s] %s %-8s [%s%s] %3d/%-3d  jobs %d/%d  %.2f jobs/s  ETA %s\n",
                       ev.elapsed_s(), ev.instant().c_str(), ev.stage().c_str(),
                       std::string(filled, '#').c_str(), std::string(width - filled, '.').c_str(),
                       ev.done(), ev.total(), ev.jobs_done(), ev.jobs_total(), rate, eta);
          std::fflush(out);
        },
        &ended);
    if (ended) next_poll = Clock::now();
  }
}

EmbeddedWorkers DefaultEmbeddedWorkers(const runtime::Session& session, int hardware_threads) {
  const int half = std::max(1, hardware_threads / 2);
  if (session.noop_jobs() > 0) return {2, half};
  int64_t instants = session.instants_size();
  if (instants == 0) instants = int64_t(take::OpenTake(session.take()).instants.size());
  return {2, instants == 1 ? std::max(1, hardware_threads) : half};
}

runtime::SessionStatus RunEmbedded(const runtime::Session& session, const EmbeddedOptions& given,
                                   std::FILE* out) {
  core::Require(given.workers >= 0, "--workers", "must be 0 (from the session) or more");
  EmbeddedOptions options = given;
  if (options.workers == 0) {
    const EmbeddedWorkers layout = DefaultEmbeddedWorkers(session, core::HardwareThreads());
    options.workers = layout.workers;
    if (options.threads_per_worker <= 0) options.threads_per_worker = layout.threads_per_worker;
  }
  zmq::context_t context;
  scheduler::MasterOptions mo = options.master;
  const std::string tag =
      std::to_string(::getpid()) + "-" + std::to_string(Clock::now().time_since_epoch().count());
  mo.worker_endpoint = "inproc://dome-workers-" + tag;
  mo.control_endpoint = "inproc://dome-control-" + tag;
  mo.events_endpoint = "inproc://dome-events-" + tag;
  scheduler::Master master(&context, mo);
  std::atomic<bool> stop_master{false}, stop_workers{false};
  std::thread master_thread([&] { master.Run(&stop_master); });
  std::vector<std::unique_ptr<worker::Worker>> workers;
  std::vector<std::thread> worker_threads;
  const int threads = options.threads_per_worker > 0
                          ? options.threads_per_worker
                          : std::max(1, core::HardwareThreads() / options.workers);
  for (int w = 0; w < options.workers; ++w) {
    worker::WorkerOptions wo;
    wo.master = mo.worker_endpoint;
    wo.threads = threads;
    wo.cache_mb = options.cache_mb;
    wo.heartbeat_interval_ms = mo.heartbeat_interval_ms;
    wo.heartbeat_liveness = mo.heartbeat_liveness;
    wo.name = "embedded-" + std::to_string(w);
    wo.stages = options.worker_stages ? options.worker_stages : mo.stages;
    workers.push_back(std::make_unique<worker::Worker>(&context, wo));
  }
  for (auto& w : workers) {
    worker::Worker* raw = w.get();
    worker_threads.emplace_back([raw, &stop_workers] { raw->Run(&stop_workers); });
  }
  auto shut_down = [&] {
    stop_workers = true;
    for (auto& t : worker_threads) t.join();
    stop_master = true;
    master_thread.join();
  };
  runtime::SessionStatus status;
  try {
    runtime::ControlRequest req;
    *req.mutable_submit()->mutable_session() = session;
    const runtime::ControlReply reply = Request(&context, mo.control_endpoint, req);
    if (out) std::fprintf(out, "session %s\n", reply.session_id().c_str());
    status = WaitForSession(&context, mo.control_endpoint, mo.events_endpoint, reply.session_id(),
                            out, 200);
  } catch (...) {
    shut_down();
    throw;
  }
  shut_down();
  return status;
}

std::string FormatCaptureStatus(const runtime::CaptureStatus& c) {
  const int width = 20;
  const int filled = c.wanted() > 0 ? width * c.captured() / c.wanted() : 0;
  char line[512];
  std::snprintf(line, sizeof line,
                "capture %-8s pass %-2d [%s%s] %4d/%-4d frames  pass yield %d  stored %lld  %s%s%s",
                c.camera_id().c_str(), c.pass(), std::string(filled, '#').c_str(),
                std::string(width - filled, '.').c_str(), c.captured(), c.wanted(), c.pass_yield(),
                static_cast<long long>(c.stored()), c.state().c_str(),
                c.error().empty() ? "" : ": ", c.error().c_str());
  return line;
}

std::map<std::string, runtime::CaptureStatus> WatchCapture(zmq::context_t* context,
                                                           const std::string& events,
                                                           std::FILE* out, int cameras,
                                                           int timeout_ms,
                                                           const net::SocketOptions& options) {
  net::EventSubscription sub(context, events, options);
  std::map<std::string, runtime::CaptureStatus> last;
  const auto end = Clock::now() + std::chrono::milliseconds(timeout_ms);
  auto finished = [&] {
    int n = 0;
    for (const auto& [camera, c] : last) n += c.state() != "capturing";
    return cameras > 0 && n >= cameras;
  };
  while (!finished() && (timeout_ms <= 0 || Clock::now() < end)) {
    sub.Drain(100, [&](const runtime::StatusEvent& ev) {
      if (!ev.has_capture()) return;
      last[ev.capture().camera_id()] = ev.capture();
      if (out != nullptr) {
        std::fprintf(out, "%s\n", FormatCaptureStatus(ev.capture()).c_str());
        std::fflush(out);
      }
    });
  }
  return last;
}

}  // namespace dome::client
