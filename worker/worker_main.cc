// dome-worker: the stateless job executor (worker/worker.h); a CURVE client of the
// master unless started with --insecure.
#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>

#include "core/error.h"
#include "core/logging.h"
#include "core/memory.h"
#include "net/security.h"
#include "worker/worker.h"

namespace {
std::atomic<bool> g_stop{false};
void OnSignal(int) { g_stop = true; }
}  // namespace

int main(int argc, char** argv) {
  dome::core::RetainFreedMemory();
  dome::core::ChoosePageSize();
  CLI::App app{"dome-worker: runs stereo, fusion, decimation and texture jobs for a dome-master"};
  dome::worker::WorkerOptions o;
  std::string log_level = "info", master_key, key;
  bool insecure = false;
  app.add_option("--master", o.master, "the master's worker endpoint, e.g. tcp://host:5555")
      ->required();
  app.add_option("--threads", o.threads, "threads per job (0: all)")->capture_default_str();
  app.add_option("--cache-mb", o.cache_mb, "blob cache, MiB")->capture_default_str();
  app.add_option("--heartbeat-ms", o.heartbeat_interval_ms, "heartbeat interval, ms")
      ->capture_default_str();
  app.add_option("--liveness", o.heartbeat_liveness, "silent intervals before reconnecting")
      ->capture_default_str();
  app.add_option("--reconnect-max-ms", o.reconnect_max_ms, "longest reconnect back-off, ms")
      ->capture_default_str();
  app.add_option("--name", o.name, "name in the master's logs (default host:pid)");
  app.add_option("--max-message-bytes", o.socket.max_message_bytes,
                 "largest message sent or accepted, bytes (the master's --max-message-bytes)")
      ->capture_default_str();
  app.add_option("--master-key", master_key, "the master's public key file (CURVE)");
  app.add_option("--key", key,
                 "this worker's secret key file, its .pub on the master's allow-list");
  app.add_flag("--insecure", insecure, "plaintext, for a master started with --insecure");
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error or off");
  CLI11_PARSE(app, argc, argv);
  try {
    dome::net::ApplyClientKeys(master_key, key, insecure, &o.socket);
    dome::core::SetUpLogging(log_level);
    std::signal(SIGINT, OnSignal);
    std::signal(SIGTERM, OnSignal);
    zmq::context_t context;
    dome::worker::Worker worker(&context, o);
    worker.Run(&g_stop);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dome-worker: %s\n", e.what());
    return 1;
  }
  return 0;
}
