// The `dome` client side of the runtime: requests on the master's control socket
// (REQ), progress from its status socket (SUB), and the embedded cluster that `dome
// run` starts when no --master is given (a Master and N Workers in this process,
// over inproc:// sockets: the same scheduler and messages as the distributed run).
#pragma once

#include <cstdio>
#include <functional>
#include <string>
#include <zmq.hpp>

#include "runtime.pb.h"
#include "scheduler/master.h"

namespace dome::client {

// Sends one control request and waits up to timeout_ms for the reply. Throws
// core::InputError naming the endpoint when the master does not answer, refuses the
// request, or answers with an error (the master's message).
runtime::ControlReply Request(zmq::context_t* context, const std::string& control_endpoint,
                              const runtime::ControlRequest& request, int timeout_ms = 10000);

// The status endpoint next to a control endpoint: the same address, port + 1
// (dome-master's defaults: workers 5555, control 5556, events 5557).
std::string EventsEndpointFor(const std::string& control_endpoint);

// One line per instant and stage: "00-00-00-01  stereo 6/6  fusion 3/10 ...".
std::string FormatStatus(const runtime::SessionStatus& status);

// Follows a session until it is done, failed or cancelled: prints progress from the
// status socket to `out` (null: silent) with job rates and an ETA, asks the control
// socket for the state every poll_ms. Returns the final status.
runtime::SessionStatus WaitForSession(zmq::context_t* context, const std::string& control_endpoint,
                                      const std::string& events_endpoint,
                                      const std::string& session_id, std::FILE* out,
                                      int poll_ms = 500);

struct EmbeddedOptions {
  int workers = 2;                  // in-process workers (count)
  int threads_per_worker = 0;       // <= 0: hardware threads / workers, at least 1
  int64_t cache_mb = 1024;          // each worker's blob cache, MiB
  scheduler::MasterOptions master;  // endpoints are replaced by inproc:// ones
};

// Runs `session` on an embedded master with in-process workers; progress to `out`.
runtime::SessionStatus RunEmbedded(const runtime::Session& session, const EmbeddedOptions& options,
                                   std::FILE* out);

}  // namespace dome::client
