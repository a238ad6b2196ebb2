// The `dome` client side of the runtime: requests on the master's control socket
// (REQ), progress from its status socket (net/events.h), and the embedded cluster that `dome
// run` starts when no --master is given (a Master and N Workers in this process,
// over inproc:// sockets: the same scheduler and messages as the distributed run).
#pragma once

#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <zmq.hpp>

#include "master/master.h"
#include "net/wire.h"
#include "runtime.pb.h"

namespace dome::client {

// Sends one control request and waits up to timeout_ms for the reply. Throws
// core::InputError naming the endpoint when the master does not answer, refuses the
// request, or answers with an error (the master's message). `socket`: CURVE keys
// (net/security.h ApplyClientKeys); the default is plaintext.
runtime::ControlReply Request(zmq::context_t* context, const std::string& control_endpoint,
                              const runtime::ControlRequest& request, int timeout_ms = 10000,
                              const net::SocketOptions& socket = net::SocketOptions{});

// The status endpoint next to a control endpoint: the same address, port + 1
// (dome-master's defaults: workers 5555, control 5556, events 5557).
std::string EventsEndpointFor(const std::string& control_endpoint);

// One line per instant and stage: "00-00-00-01  stereo 6/6  fusion 3/10 ...".
std::string FormatStatus(const runtime::SessionStatus& status);

// Every output file of a session's folder, relative path -> bytes: what two runs of
// the same session must agree on byte for byte (not the journal, the blob store, the
// report, whose timings differ, or session.json, which names the folder). For tests
// and benchmarks that compare runs.
std::map<std::string, std::string> SessionOutputFiles(const std::filesystem::path& out);

// The warning `dome run` ends with when instants of a finished session have an empty
// surface (OUT/report.json "empty_surfaces", master/master.h): how many of how many,
// which, and the volume (report.json "volume", world mm) that probably misses the
// scene. "" when there are none, or when OUT/report.json is not readable here (a
// remote master's folder) or not such a report.
std::string EmptySurfaceWarning(const std::filesystem::path& out);

// Follows a session until it is done, failed or cancelled: prints progress from the
// status socket to `out` (null: silent) with job rates and an ETA, asks the control
// socket for the state every poll_ms. Returns the final status. `socket` as for Request
// (both the control and the status socket use it).
runtime::SessionStatus WaitForSession(zmq::context_t* context, const std::string& control_endpoint,
                                      const std::string& events_endpoint,
                                      const std::string& session_id, std::FILE* out,
                                      int poll_ms = 500,
                                      const net::SocketOptions& socket = net::SocketOptions{});

// One line for a capture agent's progress (StatusEvent.capture, dome-master
// --capture-bind): camera, pass, a bar, frames captured of wanted, the pass's yield,
// frames the master stored, the state and any error.
std::string FormatCaptureStatus(const runtime::CaptureStatus& capture);

// Prints the capture progress events of the status socket, a line each, until
// `cameras` cameras have finished (0: no such end) or timeout_ms passes (0: no limit).
// Returns the last event of each camera heard from.
std::map<std::string, runtime::CaptureStatus> WatchCapture(
    zmq::context_t* context, const std::string& events_endpoint, std::FILE* out, int cameras,
    int timeout_ms, const net::SocketOptions& socket = net::SocketOptions{});

struct EmbeddedOptions {
  // In-process workers (count); 0: from the session (DefaultEmbeddedWorkers).
  int workers = 0;
  // <= 0: from the session when `workers` is 0 too, else hardware threads / workers, at
  // least 1.
  int threads_per_worker = 0;
  int64_t cache_mb = 1024;          // each worker's blob cache, MiB
  scheduler::MasterOptions master;  // endpoints are replaced by inproc:// ones
  // The stages the workers run; null: the master's (tests give them another set).
  std::shared_ptr<const pipeline::StageSet> worker_stages;
};

// The in-process workers for `session` when none are asked for, on a machine of
// `hardware_threads`: two, each with half the threads when the session has several
// instants (an instant's single jobs overlap the next instant's stereo), each with every
// thread when it has one. With one instant every stage's jobs run one after another,
// and a job has parts on one thread (a stereo job's coarse pass, speckle removal and
// file encoding, about a third of it on Robovision): with one worker the other core
// idled through them, with two the other worker's job fills it, while the lone
// decimation and texture jobs still get every thread. (The workers share the decoded
// frames and the fusion tables: frame_handoff.h, shared_fusion.h.)
struct EmbeddedWorkers {
  int workers = 2;
  int threads_per_worker = 1;
};
EmbeddedWorkers DefaultEmbeddedWorkers(const runtime::Session& session, int hardware_threads);

// Runs `session` on an embedded master with in-process workers; progress to `out`.
runtime::SessionStatus RunEmbedded(const runtime::Session& session, const EmbeddedOptions& options,
                                   std::FILE* out);

}  // namespace dome::client
