#include "net/wire.h"

#include <google/protobuf/stubs/logging.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <mutex>
#include <vector>

#include "core/error.h"
#include "net/security.h"

namespace dome::net {

void SocketOptions::Check() const {
  core::Require(max_message_bytes >= 1024, "max_message_bytes",
                "must be at least 1024 bytes, got " + std::to_string(max_message_bytes));
  core::Require(linger_ms >= 0, "linger_ms", "must not be negative");
  if (curve_client()) {
    core::Require(IsZ85Key(server_key), "server key", "is not a Z85 CURVE public key");
    core::Require(IsZ85Key(public_key) && IsZ85Key(secret_key), "key",
                  "a CURVE client needs its own Z85 public and secret keys");
  } else if (!secret_key.empty()) {
    core::Require(IsZ85Key(secret_key), "secret key", "is not a Z85 CURVE secret key");
  }
}

void ConfigureSocket(zmq::socket_t* socket, const SocketOptions& options) {
  socket->set(zmq::sockopt::linger, options.linger_ms);
  socket->set(zmq::sockopt::maxmsgsize, 2 * options.max_message_bytes);
  // Queues bounded in messages; a peer that stops reading does not grow us forever.
  socket->set(zmq::sockopt::sndhwm, 10000);
  socket->set(zmq::sockopt::rcvhwm, 10000);
  if (options.curve_client()) {
    socket->set(zmq::sockopt::curve_serverkey, options.server_key);
    socket->set(zmq::sockopt::curve_publickey, options.public_key);
    socket->set(zmq::sockopt::curve_secretkey, options.secret_key);
  } else if (options.curve_server()) {
    socket->set(zmq::sockopt::curve_server, 1);
    socket->set(zmq::sockopt::curve_secretkey, options.secret_key);
    socket->set(zmq::sockopt::zap_domain, options.zap_domain);
  }
}

std::string BoundEndpoint(const zmq::socket_t& socket) {
  return socket.get(zmq::sockopt::last_endpoint);
}

std::string EncodeEnvelope(runtime::Envelope envelope) {
  envelope.set_version(kProtocolVersion);
  std::string bytes;
  envelope.SerializeToString(&bytes);
  return bytes;
}

runtime::Envelope DecodeEnvelope(std::string_view bytes, const std::string& peer,
                                 int64_t max_bytes) {
  if (int64_t(bytes.size()) > max_bytes) {
    throw core::InputError(peer, "message of " + std::to_string(bytes.size()) +
                                     " bytes is over the cap of " + std::to_string(max_bytes));
  }
  // libprotobuf prints its own line to stderr for every malformed string field, one a
  // message a peer sends, unthrottled; the refusal below says what matters.
  static std::once_flag quiet;
  std::call_once(quiet, [] {
    google::protobuf::SetLogHandler(
        [](google::protobuf::LogLevel, const char* file, int line, const std::string& message) {
          spdlog::debug("libprotobuf {}:{}: {}", file, line, message);
        });
  });
  runtime::Envelope envelope;
  if (!envelope.ParseFromArray(bytes.data(), int(bytes.size()))) {
    throw core::InputError(peer, "message of " + std::to_string(bytes.size()) +
                                     " bytes is not a dome runtime envelope");
  }
  if (envelope.version() != kProtocolVersion) {
    throw core::InputError(peer, "speaks protocol version " + std::to_string(envelope.version()) +
                                     ", this side speaks version " +
                                     std::to_string(kProtocolVersion));
  }
  if (envelope.body_case() == runtime::Envelope::BODY_NOT_SET) {
    throw core::InputError(peer, "envelope without a message body");
  }
  return envelope;
}

std::string PeerName(std::string_view id) {
  const bool text = !id.empty() && std::all_of(id.begin(), id.end(), [](char c) {
    return std::isprint(static_cast<unsigned char>(c));
  });
  if (text) return "peer " + std::string(id);
  static const char* kHex = "0123456789abcdef";
  std::string s = "peer 0x";
  for (unsigned char c : id) {
    s += kHex[c >> 4];
    s += kHex[c & 15];
  }
  return s;
}

bool SendFrames(zmq::socket_t* socket, std::initializer_list<std::string_view> frames) {
  size_t i = 0;
  for (std::string_view f : frames) {
    const bool last = ++i == frames.size();
    const auto flags =
        (last ? zmq::send_flags::none : zmq::send_flags::sndmore) | zmq::send_flags::dontwait;
    auto sent = socket->send(zmq::buffer(f.data(), f.size()), flags);
    if (!sent) return false;
  }
  return true;
}

std::vector<zmq::message_t> ReceiveFrames(zmq::socket_t* socket) {
  std::vector<zmq::message_t> frames;
  zmq::message_t m;
  if (!socket->recv(m, zmq::recv_flags::dontwait)) return frames;
  bool more = m.more();
  frames.push_back(std::move(m));
  // The parts of a message arrive together: the rest never blocks.
  while (more) {
    zmq::message_t part;
    if (!socket->recv(part, zmq::recv_flags::none)) break;
    more = part.more();
    frames.push_back(std::move(part));
  }
  return frames;
}

bool WaitForInput(zmq::socket_t* socket, int timeout_ms) {
  zmq::pollitem_t items[] = {{socket->handle(), 0, ZMQ_POLLIN, 0}};
  try {
    zmq::poll(items, 1, std::chrono::milliseconds(timeout_ms));
  } catch (const zmq::error_t& e) {
    if (e.num() != EINTR) throw;
    return false;
  }
  return (items[0].revents & ZMQ_POLLIN) != 0;
}

}  // namespace dome::net
