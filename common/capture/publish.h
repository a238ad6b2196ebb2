// Publishing captured frames: the agent's side (FramePublisher, a ZeroMQ DEALER with a
// local spool) and the receiving side (FrameIngest, a ROUTER that stores frames into a
// take). The messages are proto/capture.proto's.
//
// Nothing is lost while the ingest is down: Publish() first writes the frame to the
// spool folder (SPOOL/<camera>_<HH-MM-SS-FF>.frame, a serialized CaptureMessage), and
// the file goes only when the ingest acknowledges the frame (stored or duplicate). A
// frame not acknowledged within ack_timeout_ms is sent again; when nothing at all comes
// back for that long the socket is rebuilt (the Lazy Pirate pattern of the ZeroMQ
// guide). A new publisher over an existing spool sends what it finds there first.
//
// The ingest writes TAKE/frames/<HH-MM-SS-FF>/<camera>.png (take/take.h's layout) via a
// temporary file and a rename, and acknowledges; a frame already in the take is a
// duplicate and left as it is. Malformed messages are answered REJECTED with the
// reason and counted; they never stop the ingest.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include "capture/pass_planner.h"

namespace dome::capture {

inline constexpr const char* kCaptureProtocol = "dome-capture/1";

struct PublisherOptions {
  std::string endpoint;             // the ingest, e.g. tcp://master:5570
  std::filesystem::path spool_dir;  // created if missing
  int ack_timeout_ms = 1000;        // resend a frame not acknowledged within this, ms
  int max_in_flight = 16;           // frames sent and not yet acknowledged
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
  void Publish(const CapturedFrame& frame);
  // Progress for status displays (best effort, not spooled).
  void SendProgress(int pass, int captured, int wanted, bool done);
  // Sends and receives for up to timeout_ms.
  void Pump(int timeout_ms);
  // Pumps until every spooled frame is acknowledged (true) or timeout_ms passes.
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
  void Receive(int timeout_ms);

  std::string camera_id_;
  PublisherOptions options_;
  struct Socket;
  std::unique_ptr<Socket> socket_;
  std::map<std::string, Pending> pending_;  // by time code text
  std::vector<take::Timecode> spooled_at_start_;
  std::chrono::steady_clock::time_point last_heard_;
  int64_t acknowledged_ = 0, resent_ = 0;
  int reconnects_ = 0;
  std::vector<std::string> rejections_;
};

struct IngestOptions {
  std::string bind;  // e.g. tcp://*:5570, tcp://127.0.0.1:* (port chosen)
  std::filesystem::path take_dir;
  size_t max_message_bytes = 64u << 20;  // larger messages are rejected unread
};

class FrameIngest {
 public:
  // Binds; throws core::InputError naming the address or the take folder.
  explicit FrameIngest(const IngestOptions& options);
  ~FrameIngest();
  FrameIngest(const FrameIngest&) = delete;
  FrameIngest& operator=(const FrameIngest&) = delete;

  std::string endpoint() const;  // the bound address, port resolved
  // Serves messages for up to timeout_ms.
  void Poll(int timeout_ms);

  int64_t stored() const { return stored_; }
  int64_t duplicates() const { return duplicates_; }
  int64_t rejected() const { return rejected_; }
  struct Progress {
    int pass = 0, captured = 0, wanted = 0;
    bool done = false;
  };
  const std::map<std::string, Progress>& progress() const { return progress_; }

 private:
  std::string Handle(const std::string& peer, const std::string& bytes);

  IngestOptions options_;
  struct Socket;
  std::unique_ptr<Socket> socket_;
  int64_t stored_ = 0, duplicates_ = 0, rejected_ = 0;
  std::map<std::string, Progress> progress_;
};

}  // namespace dome::capture
