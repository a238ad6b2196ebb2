// Captured frames over the network (seed §2.1): the agent's side (FramePublisher, a ZeroMQ DEALER
// with a local spool) and the receiving side (FrameIngest, a ROUTER that stores frames into a
// take). The messages are proto/capture.proto's.
//
// Nothing is lost while the ingest is down: Publish() first writes the frame to the
// spool folder (SPOOL/<camera>_<HH-MM-SS-FF>.frame, a serialized CaptureMessage), and
// the file goes only when the ingest acknowledges the frame (stored or duplicate). A
// frame not acknowledged within ack_timeout_ms is sent again; when nothing at all comes
// back for that long the socket is rebuilt (the Lazy Pirate pattern of the ZeroMQ
// guide). A new publisher over an existing spool sends what it finds there first.
//
// Progress travels on the same connection: a few messages a second, not spooled; the
// final one (done) is resent until acknowledged, on every new socket too, so the
// ingest always learns the final count unless the agent gives up flushing.
//
// The ingest writes TAKE/frames/<HH-MM-SS-FF>/<camera>.png (take/take.h's layout) via a
// temporary file and a rename, and acknowledges; a frame already in the take is a
// duplicate and left as it is. Malformed messages are answered REJECTED with the
// reason and counted; they never stop the ingest. dome-master hosts one in its poll
// loop (--capture-bind); `dome-capture ingest` runs one on its own.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include "capture/pass_planner.h"
#include "net/wire.h"

namespace dome::ingest {

// One agent's progress (proto/capture.proto CaptureProgress).
struct AgentProgress {
  int pass = 0;              // current pass, 1-based
  int captured = 0;          // frames of the range captured so far
  int wanted = 0;            // frames in the range
  int pass_yield = 0;        // frames this pass captured for the first time
  int64_t acknowledged = 0;  // frames the ingest acknowledged so far
  bool done = false;         // the agent finished (complete or gave up)
  std::string error;         // why it gave up or the last pass ended early; "" if none
};

inline constexpr const char* kCaptureProtocol = "dome-capture/1";

struct PublisherOptions {
  std::string endpoint;               // the ingest, e.g. tcp://master:5570
  std::filesystem::path spool_dir;    // created if missing
  int ack_timeout_ms = 1000;          // resend a frame not acknowledged within this, ms
  int max_in_flight = 16;             // frames sent and not yet acknowledged (count)
  net::SocketOptions socket{};        // CURVE keys (net/security.h); plaintext by default
  zmq::context_t* context = nullptr;  // optional; the publisher's own when null

  // Throws core::InputError naming the first option out of range ("endpoint").
  void Check() const;
};

class FramePublisher {
 public:
  // Opens the spool (throws core::InputError naming it when it cannot be created) and
  // queues any frames left there by an earlier run.
  FramePublisher(const std::string& camera_id, const PublisherOptions& options);
  ~FramePublisher();
  FramePublisher(const FramePublisher&) = delete;
  FramePublisher& operator=(const FramePublisher&) = delete;

  // Spools `frame` and sends it when the window allows. Returns at once.
  void Publish(const capture::CapturedFrame& frame);
  // Progress for status displays: best effort, not spooled; with `done` set it is
  // resent until acknowledged (Flush waits for it). `acknowledged` is filled in here.
  void SendProgress(AgentProgress progress);
  // Sends and receives for up to timeout_ms.
  void Pump(int timeout_ms);
  // Pumps until every spooled frame and the final progress are acknowledged (true) or
  // timeout_ms passes.
  bool Flush(int timeout_ms);

  size_t pending() const { return pending_.size(); }
  // Time codes found in the spool at start-up (already captured, not yet delivered).
  const std::vector<take::Timecode>& spooled_at_start() const { return spooled_at_start_; }
  int64_t acknowledged() const { return acknowledged_; }
  int64_t resent() const { return resent_; }
  int reconnects() const { return reconnects_; }
  // REJECTED acknowledgements, with the ingest's reasons.
  const std::vector<std::string>& rejections() const { return rejections_; }

 private:
  struct Pending {
    std::filesystem::path spool_file;
    std::string message;  // serialized CaptureMessage
    std::chrono::steady_clock::time_point sent_at{};
    bool sent = false;
  };
  void Connect();
  void SendDue();
  bool AllAcknowledged() const;
  void Receive(int timeout_ms);

  std::string camera_id_;
  PublisherOptions options_;
  struct Socket;
  std::unique_ptr<Socket> socket_;
  std::map<std::string, Pending> pending_;  // by time code text
  uint64_t run_id_ = 0;  // random, tells this run's progress from an earlier one's
  uint32_t progress_sequence_ = 0;
  std::string last_progress_;            // serialized CaptureMessage; "" before any
  bool final_progress_pending_ = false;  // the done progress awaits its acknowledgement
  std::chrono::steady_clock::time_point progress_sent_at_{};
  std::vector<take::Timecode> spooled_at_start_;
  std::chrono::steady_clock::time_point last_heard_;
  int64_t acknowledged_ = 0, resent_ = 0;
  int reconnects_ = 0;
  std::vector<std::string> rejections_;
};

// What the ingest heard from one camera's agent, and what it stored for it.
struct IngestProgress {
  std::string camera_id;
  AgentProgress agent;    // the latest progress message
  int64_t stored = 0;     // frames of this camera this ingest stored (not duplicates)
  uint64_t run_id = 0;    // of the agent run `agent` came from
  uint32_t sequence = 0;  // of that message within the run
};

struct IngestOptions {
  std::string bind;  // e.g. tcp://*:5570, tcp://127.0.0.1:* (port chosen)
  std::filesystem::path take_dir;
  size_t max_message_bytes = 64u << 20;  // larger messages are rejected unread, bytes
  net::SocketOptions socket{};           // CURVE server key (net/security.h); plaintext by default
  zmq::context_t* context = nullptr;     // optional; the ingest's own when null
  // Called from Poll() on every progress message (e.g. to republish it).
  std::function<void(const IngestProgress&)> on_progress{};

  // Throws core::InputError naming the first option out of range ("bind", "take_dir").
  void Check() const;
};

class FrameIngest {
 public:
  // Binds; throws core::InputError naming the address or the take folder.
  explicit FrameIngest(const IngestOptions& options);
  ~FrameIngest();
  FrameIngest(const FrameIngest&) = delete;
  FrameIngest& operator=(const FrameIngest&) = delete;

  std::string endpoint() const;  // the bound address, port resolved
  // Serves messages for up to timeout_ms (0: only what is waiting).
  void Poll(int timeout_ms);
  // The socket, for a caller's zmq::poll (ZMQ_POLLIN means Poll(0) has work).
  zmq::socket_t& socket();

  int64_t stored() const { return stored_; }
  int64_t duplicates() const { return duplicates_; }
  int64_t rejected() const { return rejected_; }
  // By camera.
  const std::map<std::string, IngestProgress>& progress() const { return progress_; }

 private:
  std::string Handle(const std::string& peer, const std::string& bytes);

  IngestOptions options_;
  struct Socket;
  std::unique_ptr<Socket> socket_;
  int64_t stored_ = 0, duplicates_ = 0, rejected_ = 0;
  std::map<std::string, IngestProgress> progress_;
};

}  // namespace dome::ingest
