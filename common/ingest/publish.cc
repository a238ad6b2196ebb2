#include "ingest/publish.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <fstream>
#include <optional>
#include <random>
#include <zmq.hpp>

#include "capture.pb.h"
#include "core/error.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "take/timecode.h"

namespace dome::ingest {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

bool ValidCameraId(const std::string& id) {
  if (id.empty() || id.size() > 64) return false;
  return std::all_of(id.begin(), id.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
  });
}

// "HH:MM:SS:FF" -> the instant folder name, or nullopt.
std::optional<take::Timecode> ParseWireTimecode(const std::string& text) {
  if (text.size() != 11) return std::nullopt;
  std::string name = text;
  for (size_t i : {2u, 5u, 8u}) {
    if (name[i] != ':' && name[i] != ';') return std::nullopt;
    name[i] = '-';
  }
  return take::ParseInstantName(name);
}

}  // namespace

void PublisherOptions::Check() const {
  core::Require(!endpoint.empty(), "endpoint", "expected the ingest's address, e.g. tcp://host:5570");
  core::Require(!spool_dir.empty(), "spool_dir", "expected a folder for unacknowledged frames");
  core::Require(ack_timeout_ms > 0, "ack_timeout_ms",
                "must be positive, got " + std::to_string(ack_timeout_ms));
  core::Require(max_in_flight >= 1, "max_in_flight",
                "must be at least 1, got " + std::to_string(max_in_flight));
  socket.Check();
}

void IngestOptions::Check() const {
  core::Require(!bind.empty(), "bind", "expected an address to bind, e.g. tcp://*:5570");
  core::Require(!take_dir.empty(), "take_dir", "expected the take folder frames go into");
  core::Require(max_message_bytes >= 1024, "max_message_bytes",
                "must be at least 1024 bytes, got " + std::to_string(max_message_bytes));
  socket.Check();
}

// --- publisher -----------------------------------------------------------------------

struct FramePublisher::Socket {
  std::unique_ptr<zmq::context_t> own_context;
  zmq::context_t* context = nullptr;
  std::unique_ptr<zmq::socket_t> socket;
};

FramePublisher::FramePublisher(const std::string& camera_id, const PublisherOptions& options)
    : camera_id_(camera_id), options_(options), socket_(std::make_unique<Socket>()) {
  run_id_ = (uint64_t{std::random_device{}()} << 32) ^ std::random_device{}() ^
            static_cast<uint64_t>(Clock::now().time_since_epoch().count());
  socket_->context = options.context;
  if (socket_->context == nullptr) {
    socket_->own_context = std::make_unique<zmq::context_t>(1);
    socket_->context = socket_->own_context.get();
  }
  core::Require(ValidCameraId(camera_id), "camera_id",
                "expected letters, digits, '_' or '-', got '" + camera_id + "'");
  options.Check();
  std::error_code ec;
  fs::create_directories(options.spool_dir, ec);
  core::Require(fs::is_directory(options.spool_dir), options.spool_dir.string(),
                "cannot create the spool folder: " + ec.message());
  // Frames an earlier run spooled and never saw acknowledged.
  const std::string prefix = camera_id + "_";
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(options.spool_dir)) {
    const std::string name = entry.path().filename().string();
    if (entry.path().extension() == ".frame" && name.rfind(prefix, 0) == 0)
      files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  for (const auto& file : files) {
    Pending p;
    p.spool_file = file;
    p.message = io::ReadFileBytes(file);
    proto::CaptureMessage message;
    if (!message.ParseFromString(p.message) || !message.has_frame()) {
      spdlog::warn("capture: {}: not a spooled frame; left alone", file.string());
      continue;
    }
    if (const auto tc = ParseWireTimecode(message.frame().timecode()))
      spooled_at_start_.push_back(*tc);
    pending_[message.frame().timecode()] = std::move(p);
  }
  Connect();
}

FramePublisher::~FramePublisher() = default;

void FramePublisher::Connect() {
  socket_->socket = std::make_unique<zmq::socket_t>(*socket_->context, zmq::socket_type::dealer);
  net::ConfigureSocket(socket_->socket.get(), options_.socket);
  socket_->socket->set(zmq::sockopt::linger, 0);
  socket_->socket->set(zmq::sockopt::reconnect_ivl, 100);
  socket_->socket->set(zmq::sockopt::routing_id, camera_id_);
  try {
    socket_->socket->connect(options_.endpoint);
  } catch (const zmq::error_t& e) {
    throw core::InputError("endpoint " + options_.endpoint,
                           std::string("cannot connect: ") + e.what());
  }
  last_heard_ = Clock::now();
  for (auto& [tc, p] : pending_) p.sent = false;  // resend everything on the new socket
  // The latest progress, so a restarted ingest shows this agent at once.
  if (!last_progress_.empty()) {
    net::SendFrames(socket_->socket.get(), {last_progress_});
    progress_sent_at_ = Clock::now();
  }
}

bool FramePublisher::AllAcknowledged() const {
  return pending_.empty() && !final_progress_pending_;
}

void FramePublisher::Publish(const capture::CapturedFrame& frame) {
  proto::CaptureMessage message;
  message.set_protocol(kCaptureProtocol);
  proto::CaptureFrame* f = message.mutable_frame();
  f->set_camera_id(camera_id_);
  f->set_timecode(frame.time.Text());
  f->set_field(1);
  f->set_width_px(frame.take_image.cols);
  f->set_height_px(frame.take_image.rows);
  const cv::Mat image =
      frame.take_image.isContinuous() ? frame.take_image : frame.take_image.clone();
  f->set_pixels(image.data, image.total());
  f->set_pass(frame.pass);
  Pending p;
  p.message = message.SerializeAsString();
  p.spool_file = options_.spool_dir / (camera_id_ + "_" + frame.time.FolderName() + ".frame");
  io::WriteFileAtomically(p.spool_file, p.message);
  pending_[f->timecode()] = std::move(p);
  Pump(0);
}

void FramePublisher::SendProgress(AgentProgress progress) {
  progress.acknowledged = acknowledged_;
  proto::CaptureMessage message;
  message.set_protocol(kCaptureProtocol);
  proto::CaptureProgress* p = message.mutable_progress();
  p->set_camera_id(camera_id_);
  p->set_pass(progress.pass);
  p->set_captured(progress.captured);
  p->set_wanted(progress.wanted);
  p->set_done(progress.done);
  p->set_pass_yield(progress.pass_yield);
  p->set_acknowledged(static_cast<int32_t>(progress.acknowledged));
  p->set_error(progress.error);
  p->set_run_id(run_id_);
  p->set_sequence(++progress_sequence_);
  last_progress_ = message.SerializeAsString();
  final_progress_pending_ = progress.done;
  progress_sent_at_ = Clock::now();
  net::SendFrames(socket_->socket.get(), {last_progress_});
}

void FramePublisher::SendDue() {
  const auto now = Clock::now();
  const auto timeout = std::chrono::milliseconds(options_.ack_timeout_ms);
  int in_flight = 0;
  for (const auto& [tc, p] : pending_) in_flight += p.sent && now - p.sent_at < timeout;
  for (auto& [tc, p] : pending_) {
    if (in_flight >= options_.max_in_flight) break;
    if (p.sent && now - p.sent_at < timeout) continue;
    if (p.sent) ++resent_;
    if (!net::SendFrames(socket_->socket.get(), {p.message})) break;
    p.sent = true;
    p.sent_at = now;
    ++in_flight;
  }
  if (final_progress_pending_ && now - progress_sent_at_ >= timeout) {
    net::SendFrames(socket_->socket.get(), {last_progress_});
    progress_sent_at_ = now;
  }
}

void FramePublisher::Receive(int timeout_ms) {
  net::WaitForInput(socket_->socket.get(), timeout_ms);
  for (auto frames = net::ReceiveFrames(socket_->socket.get()); !frames.empty();
       frames = net::ReceiveFrames(socket_->socket.get())) {
    last_heard_ = Clock::now();
    proto::CaptureAck ack;
    if (frames.size() != 1 ||
        !ack.ParseFromArray(frames[0].data(), static_cast<int>(frames[0].size())) ||
        ack.protocol() != kCaptureProtocol) {
      spdlog::warn("capture: peer {}: a reply that is not a {} acknowledgement; ignored",
                   options_.endpoint, kCaptureProtocol);
      continue;
    }
    if (ack.progress()) {
      final_progress_pending_ = false;
      continue;
    }
    const auto it = pending_.find(ack.timecode());
    if (it == pending_.end()) continue;  // a late acknowledgement of a resent frame
    if (ack.status() == proto::CaptureAck::REJECTED) {
      rejections_.push_back(ack.timecode() + ": " + ack.error());
      spdlog::error("capture: peer {} rejected frame {}: {}", options_.endpoint, ack.timecode(),
                    ack.error());
      pending_.erase(it);  // kept in the spool for inspection; resending cannot help
      continue;
    }
    std::error_code ec;
    fs::remove(it->second.spool_file, ec);
    pending_.erase(it);
    ++acknowledged_;
  }
}

void FramePublisher::Pump(int timeout_ms) {
  const auto end = Clock::now() + std::chrono::milliseconds(timeout_ms);
  do {
    // Silence for a whole time-out with frames outstanding: the ingest went away or
    // restarted; a fresh socket drops whatever the old one still queued.
    const bool outstanding =
        final_progress_pending_ ||
        std::any_of(pending_.begin(), pending_.end(), [](const auto& e) { return e.second.sent; });
    if (outstanding &&
        Clock::now() - last_heard_ > std::chrono::milliseconds(options_.ack_timeout_ms)) {
      ++reconnects_;
      Connect();
    }
    SendDue();
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count();
    Receive(static_cast<int>(std::clamp<int64_t>(left, 0, 50)));
  } while (Clock::now() < end && !AllAcknowledged());
}

bool FramePublisher::Flush(int timeout_ms) {
  Pump(timeout_ms);
  return AllAcknowledged();
}

// --- ingest --------------------------------------------------------------------------

struct FrameIngest::Socket {
  std::unique_ptr<zmq::context_t> own_context;
  std::unique_ptr<zmq::socket_t> socket_ptr;
  zmq::socket_t& socket() { return *socket_ptr; }
};

FrameIngest::FrameIngest(const IngestOptions& options)
    : options_(options), socket_(std::make_unique<Socket>()) {
  options.Check();
  std::error_code ec;
  fs::create_directories(options.take_dir / "frames", ec);
  core::Require(fs::is_directory(options.take_dir / "frames"), options.take_dir.string(),
                "cannot create the take's frames/ folder: " + ec.message());
  zmq::context_t* context = options.context;
  if (context == nullptr) {
    socket_->own_context = std::make_unique<zmq::context_t>(1);
    context = socket_->own_context.get();
  }
  socket_->socket_ptr = std::make_unique<zmq::socket_t>(*context, zmq::socket_type::router);
  net::ConfigureSocket(socket_->socket_ptr.get(), options.socket);
  socket_->socket().set(zmq::sockopt::linger, 0);
  socket_->socket().set(zmq::sockopt::maxmsgsize, static_cast<int64_t>(options.max_message_bytes));
  // An agent that rebuilt its socket comes back under the same identity (its camera).
  socket_->socket().set(zmq::sockopt::router_handover, 1);
  try {
    socket_->socket().bind(options.bind);
  } catch (const zmq::error_t& e) {
    throw core::InputError("bind " + options.bind, std::string("cannot bind: ") + e.what());
  }
}

FrameIngest::~FrameIngest() = default;

std::string FrameIngest::endpoint() const {
  return socket_->socket().get(zmq::sockopt::last_endpoint);
}

zmq::socket_t& FrameIngest::socket() { return socket_->socket(); }

void FrameIngest::Poll(int timeout_ms) {
  net::WaitForInput(&socket_->socket(), timeout_ms);
  for (auto frames = net::ReceiveFrames(&socket_->socket()); !frames.empty();
       frames = net::ReceiveFrames(&socket_->socket())) {
    const std::string identity = frames[0].to_string();
    const std::string peer = net::PeerName(identity);
    // A well-behaved agent sends one part after its routing id.
    auto reject = [&](const std::string& why) {
      ++rejected_;
      proto::CaptureAck ack;
      ack.set_protocol(kCaptureProtocol);
      ack.set_status(proto::CaptureAck::REJECTED);
      ack.set_error(why);
      return ack.SerializeAsString();
    };
    std::string reply;
    if (frames.size() != 2) {
      reply = reject("expected one message part per frame");
    } else {
      try {
        reply = Handle(peer, frames[1].to_string());
      } catch (const std::exception& e) {  // e.g. the take folder became unwritable
        reply = reject(std::string("cannot store the frame: ") + e.what());
        spdlog::error("ingest: {}: cannot store the frame: {}", peer, e.what());
      }
    }
    if (!reply.empty()) net::SendFrames(&socket_->socket(), {identity, reply});
  }
}

std::string FrameIngest::Handle(const std::string& peer, const std::string& bytes) {
  proto::CaptureAck ack;
  ack.set_protocol(kCaptureProtocol);
  auto reject = [&](const std::string& why) {
    ++rejected_;
    ack.set_status(proto::CaptureAck::REJECTED);
    ack.set_error(why);
    spdlog::warn("ingest: {}: {}", peer, why);
    return ack.SerializeAsString();
  };
  proto::CaptureMessage message;
  if (!message.ParseFromString(bytes))
    return reject("not a CaptureMessage (protobuf parse failed)");
  if (message.protocol() != kCaptureProtocol) {
    return reject("protocol '" + message.protocol() + "', expected '" + kCaptureProtocol + "'");
  }
  if (message.has_progress()) {
    const auto& p = message.progress();
    if (!ValidCameraId(p.camera_id()))
      return reject("progress for camera_id '" + p.camera_id() +
                    "': expected letters, digits, '_' or '-'");
    IngestProgress& entry = progress_[p.camera_id()];
    // An older message of the same run (overtaken after a socket rebuild, or resent):
    // not shown, but a final one is still acknowledged.
    const bool stale = entry.run_id == p.run_id() && p.sequence() <= entry.sequence;
    if (stale) {
      if (!p.done()) return "";
      ack.set_camera_id(p.camera_id());
      ack.set_progress(true);
      return ack.SerializeAsString();
    }
    entry.run_id = p.run_id();
    entry.sequence = p.sequence();
    entry.camera_id = p.camera_id();
    entry.agent.pass = p.pass();
    entry.agent.captured = p.captured();
    entry.agent.wanted = p.wanted();
    entry.agent.pass_yield = p.pass_yield();
    entry.agent.acknowledged = p.acknowledged();
    entry.agent.done = p.done();
    entry.agent.error = p.error();
    spdlog::debug("ingest: {} pass {}: {}/{} frames{}", p.camera_id(), p.pass(), p.captured(),
                  p.wanted(), p.done() ? " (done)" : "");
    if (options_.on_progress) options_.on_progress(entry);
    if (!p.done()) return "";
    ack.set_camera_id(p.camera_id());
    ack.set_progress(true);
    return ack.SerializeAsString();
  }
  if (!message.has_frame()) return reject("a message with neither frame nor progress");
  const proto::CaptureFrame& f = message.frame();
  ack.set_camera_id(f.camera_id());
  ack.set_timecode(f.timecode());
  if (!ValidCameraId(f.camera_id()))
    return reject("camera_id '" + f.camera_id() + "': expected letters, digits, '_' or '-'");
  const auto tc = ParseWireTimecode(f.timecode());
  if (!tc) return reject("timecode '" + f.timecode() + "': expected HH:MM:SS:FF");
  if (f.field() != 1)
    return reject("field " + std::to_string(f.field()) + ": only the first field (1) is stored");
  if (f.width_px() <= 0 || f.height_px() <= 0 || f.width_px() > 8192 || f.height_px() > 8192 ||
      f.pixels().size() != static_cast<size_t>(f.width_px()) * static_cast<size_t>(f.height_px())) {
    return reject("frame " + f.timecode() + ": " + std::to_string(f.pixels().size()) +
                  " pixel bytes for " + std::to_string(f.width_px()) + " x " +
                  std::to_string(f.height_px()) + " (expected width * height)");
  }
  const fs::path path = options_.take_dir / "frames" / tc->FolderName() / (f.camera_id() + ".png");
  if (fs::exists(path)) {
    ++duplicates_;
    ack.set_status(proto::CaptureAck::DUPLICATE);
    return ack.SerializeAsString();
  }
  fs::create_directories(path.parent_path());
  const cv::Mat image(f.height_px(), f.width_px(), CV_8UC1, const_cast<char*>(f.pixels().data()));
  io::WriteFileAtomically(path, io::EncodePng(image));  // a photograph: kSmall
  ++stored_;
  ++progress_[f.camera_id()].stored;
  progress_[f.camera_id()].camera_id = f.camera_id();
  ack.set_status(proto::CaptureAck::STORED);
  return ack.SerializeAsString();
}

}  // namespace dome::ingest
