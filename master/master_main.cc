// dome-master: the scheduler daemon (scheduler/master.h).
#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>

#include "core/logging.h"
#include "io/file_util.h"
#include "scheduler/master.h"

namespace {
std::atomic<bool> g_stop{false};
void OnSignal(int) { g_stop = true; }
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"dome-master: schedules stereo and fusion jobs to dome-workers over ZeroMQ"};
  dome::scheduler::MasterOptions o;
  std::string log_level = "info", endpoints_file;
  app.add_option("--bind", o.worker_endpoint, "ROUTER endpoint workers connect to")
      ->capture_default_str();
  app.add_option("--control", o.control_endpoint, "ROUTER endpoint for dome clients")
      ->capture_default_str();
  app.add_option("--events", o.events_endpoint, "PUB endpoint for status events")
      ->capture_default_str();
  app.add_option("--heartbeat-ms", o.heartbeat_interval_ms, "heartbeat interval, ms")
      ->capture_default_str();
  app.add_option("--liveness", o.heartbeat_liveness, "silent intervals before a worker is lost")
      ->capture_default_str();
  app.add_option("--max-message-bytes", o.socket.max_message_bytes,
                 "largest message accepted, bytes")
      ->capture_default_str();
  app.add_option("--endpoints-file", endpoints_file,
                 "write the bound endpoints here (workers, control, events; one a line)");
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error or off");
  CLI11_PARSE(app, argc, argv);
  try {
    dome::core::SetUpLogging(log_level);
    std::signal(SIGINT, OnSignal);
    std::signal(SIGTERM, OnSignal);
    zmq::context_t context;
    dome::scheduler::Master master(&context, o);
    const auto& e = master.endpoints();
    std::printf("workers %s\ncontrol %s\nevents %s\n", e.workers.c_str(), e.control.c_str(),
                e.events.c_str());
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
