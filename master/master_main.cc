// dome-master: the scheduler daemon (master/master.h). Its sockets are CURVE
// servers with a ZAP allow-list (net/security.h) unless started with --insecure.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <memory>

#include "core/logging.h"
#include "core/memory.h"
#include "io/file_util.h"
#include "master/master.h"
#include "net/security.h"

namespace {
std::atomic<bool> g_stop{false};
void OnSignal(int) { g_stop = true; }
}  // namespace

int main(int argc, char** argv) {
  dome::core::RetainFreedMemory();
  dome::core::ChoosePageSize();
  CLI::App app{"dome-master: schedules stereo and fusion jobs to dome-workers over ZeroMQ"};
  dome::scheduler::MasterOptions o;
  o.release_memory_s = 5;  // a daemon: what peers sent goes back to the system
  std::string log_level = "info", endpoints_file, keys_dir, secret_key, allow;
  bool insecure = false;
  app.add_option("--bind", o.worker_endpoint, "ROUTER endpoint workers connect to")
      ->capture_default_str();
  app.add_option("--control", o.control_endpoint, "ROUTER endpoint for dome clients")
      ->capture_default_str();
  app.add_option("--events", o.events_endpoint,
                 "endpoint of the status events (ROUTER; subscribers: net/events.h)")
      ->capture_default_str();
  app.add_option("--heartbeat-ms", o.heartbeat_interval_ms, "heartbeat interval, ms")
      ->capture_default_str();
  app.add_option("--liveness", o.heartbeat_liveness, "silent intervals before a worker is lost")
      ->capture_default_str();
  app.add_option("--writer-threads", o.writer_threads,
                 "threads checking and writing results (0 = half the hardware threads)")
      ->capture_default_str();
  app.add_option("--job-timeout-s", o.job_timeout_s,
                 "seconds a worker job may run before it is re-queued elsewhere (0: derived "
                 "from its stage and input size, see --job-timeout-min-s)")
      ->capture_default_str();
  app.add_option("--job-timeout-min-s", o.job_timeout_min_s,
                 "derived time-outs: the least, s; a stage's first job gets this plus "
                 "--job-timeout-first-s-per-mib per MiB of its inputs, later ones "
                 "--job-timeout-factor times the slowest rate seen")
      ->capture_default_str();
  app.add_option("--job-timeout-first-s-per-mib", o.job_timeout_first_s_per_mib,
                 "derived time-outs: seconds per input MiB before a stage's first job ends")
      ->capture_default_str();
  app.add_option("--job-timeout-factor", o.job_timeout_factor,
                 "derived time-outs: times the slowest seconds per input MiB seen")
      ->capture_default_str();
  app.add_option("--max-job-mb", o.max_job_mb,
                 "memory a worker job may use, MiB; larger fusion slabs are refused at "
                 "submit (0: this machine's memory)")
      ->capture_default_str();
  app.add_option("--state", o.state_dir,
                 "folder where the master keeps its sessions; started again on it, it resumes "
                 "those that had not ended, under their ids");
  app.add_option("--out-root", o.out_root,
                 "sessions may write only inside this folder (their Session.out); refused "
                 "outside it. Unset: anywhere this user may write");
  app.add_option("--max-message-bytes", o.socket.max_message_bytes,
                 "largest message accepted, bytes")
      ->capture_default_str();
  app.add_option("--endpoints-file", endpoints_file,
                 "write the bound endpoints here (workers, control, events; one a line)");
  app.add_option("--keys", keys_dir, "folder with master.key and allowed_keys (CURVE)");
  app.add_option("--secret-key", secret_key, "the master's secret key file (dome keygen)");
  app.add_option("--allow", allow, "allow-list: public keys of workers and clients, one a line");
  app.add_flag("--insecure", insecure, "plaintext, anyone may connect (no keys)");
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error or off");
  app.add_option("--capture-bind", o.capture_endpoint,
                 "ROUTER endpoint capture agents (dome-capture --master) publish frames to");
  app.add_option("--take", o.capture_take, "take folder captured frames go into (--capture-bind)");
  CLI11_PARSE(app, argc, argv);
  try {
    dome::core::SetUpLogging(log_level);
    std::signal(SIGINT, OnSignal);
    std::signal(SIGTERM, OnSignal);
    const auto allowed =
        dome::net::ApplyServerKeys(keys_dir, secret_key, allow, insecure, &o.socket);
    zmq::context_t context;
    // Declared before the master so that it outlives the master's sockets.
    std::unique_ptr<dome::net::ZapHandler> zap;
    if (!insecure) zap = std::make_unique<dome::net::ZapHandler>(&context, allowed, false);
    if (o.out_root.empty()) {
      spdlog::warn(
          "no --out-root: a client may have this master write sessions anywhere its user may");
    }
    dome::scheduler::Master master(&context, o);
    const auto& e = master.endpoints();
    std::printf("workers %s\ncontrol %s\nevents %s\n", e.workers.c_str(), e.control.c_str(),
                e.events.c_str());
    if (!e.capture.empty()) std::printf("capture %s\n", e.capture.c_str());
    if (insecure) {
      std::printf("insecure: plaintext sockets, any peer may connect\n");
    } else {
      std::printf("CURVE: %zu public keys allowed\n", allowed.size());
    }
    std::fflush(stdout);
    if (!endpoints_file.empty()) {
      dome::io::WriteFileAtomically(endpoints_file,
                                    e.workers + "\n" + e.control + "\n" + e.events + "\n");
    }
    master.Run(&g_stop);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dome-master: %s\n", e.what());
    return 1;
  }
  return 0;
}
