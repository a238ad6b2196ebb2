// dome-worker's job executor (SPEC.md "Stateless workers"; the ZeroMQ guide's
// Paranoid Pirate worker): a DEALER socket to the master's ROUTER.
//
// It says Hello with its capacity, runs one job at a time on a job thread (with
// `threads` threads inside the job), fetches the blobs a job names that are not in its
// LRU cache (bounded by cache_mb) and returns the outputs. Jobs the master sends ahead
// wait in a queue, their blobs fetched while the running job computes. Heartbeats go both ways
// every heartbeat_interval_ms; a master silent for heartbeat_liveness intervals is
// presumed gone: the worker rebuilds its socket and says Hello again after a back-off
// that doubles from one interval up to reconnect_max_ms. Malformed messages from the
// master are logged and ignored.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <zmq.hpp>

#include "net/wire.h"
#include "pipeline/stage.h"

namespace dome::worker {

struct WorkerOptions {
  std::string master = "tcp://localhost:5555";  // the master's worker endpoint
  int threads = 0;                              // threads per job; <= 0: all hardware threads
  int64_t cache_mb = 1024;                      // blob cache bound, MiB
  int heartbeat_interval_ms = 1000;             // between heartbeats, ms
  int heartbeat_liveness = 3;    // silent intervals before the master is presumed gone
  int reconnect_max_ms = 32000;  // longest back-off between reconnects, ms
  std::string name;              // for the master's logs; default host:pid
  net::SocketOptions socket;
  // The stages it runs jobs of (the master's set).
  std::shared_ptr<const pipeline::StageSet> stages = pipeline::DefaultStages();

  // Throws core::InputError naming the first option out of range.
  void Check() const;
};

struct WorkerStats {
  int64_t jobs = 0;
  int64_t failed_jobs = 0;
  int64_t reconnects = 0;
  int64_t blobs_fetched = 0;
  int64_t bytes_fetched = 0;
};

class Worker {
 public:
  Worker(zmq::context_t* context, const WorkerOptions& options);
  ~Worker();
  Worker(const Worker&) = delete;
  Worker& operator=(const Worker&) = delete;

  // Serves until *stop becomes true (checked every few ms); waits for a running job.
  void Run(const std::atomic<bool>* stop);
  WorkerStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dome::worker
