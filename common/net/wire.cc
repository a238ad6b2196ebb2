#include "net/wire.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
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

namespace {

// The length of the valid UTF-8 sequence at text[i] (RFC 3629: no overlong forms, no
// surrogates, nothing above U+10FFFF), or 0.
size_t Utf8Sequence(std::string_view text, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char c = byte(i);
  if (c < 0x80) return 1;
  size_t n = 0;
  unsigned char lo = 0x80, hi = 0xBF;  // range of the second byte
  if (c >= 0xC2 && c <= 0xDF) {
    n = 2;
  } else if (c >= 0xE0 && c <= 0xEF) {
    n = 3;
    if (c == 0xE0) lo = 0xA0;
    if (c == 0xED) hi = 0x9F;
  } else if (c >= 0xF0 && c <= 0xF4) {
    n = 4;
    if (c == 0xF0) lo = 0x90;
    if (c == 0xF4) hi = 0x8F;
  } else {
    return 0;
  }
  if (i + n > text.size() || byte(i + 1) < lo || byte(i + 1) > hi) return 0;
  for (size_t k = 2; k < n; ++k) {
    if ((byte(i + k) & 0xC0) != 0x80) return 0;
  }
  return n;
}

// U+10FF00 + b, in UTF-8: F4 8F (BC + b / 64) (80 + b % 64).
bool IsEscape(std::string_view text, size_t i) {
  return i + 4 <= text.size() && static_cast<unsigned char>(text[i]) == 0xF4 &&
         static_cast<unsigned char>(text[i + 1]) == 0x8F &&
         static_cast<unsigned char>(text[i + 2]) >= 0xBC &&
         (static_cast<unsigned char>(text[i + 3]) & 0xC0) == 0x80;
}

void AppendEscape(unsigned char b, std::string* out) {
  out->push_back(char(0xF4));
  out->push_back(char(0x8F));
  out->push_back(char(0xBC + (b >> 6)));
  out->push_back(char(0x80 + (b & 0x3F)));
}

// Every string field of `m` and its messages through `f` (bytes fields untouched).
void MapStrings(google::protobuf::Message* m, std::string (*f)(std::string_view)) {
  const auto* d = m->GetDescriptor();
  const auto* r = m->GetReflection();
  for (int i = 0; i < d->field_count(); ++i) {
    const auto* field = d->field(i);
    const auto type = field->type();
    if (type == google::protobuf::FieldDescriptor::TYPE_STRING) {
      if (field->is_repeated()) {
        for (int k = 0; k < r->FieldSize(*m, field); ++k) {
          const std::string& v = r->GetRepeatedStringReference(*m, field, k, nullptr);
          std::string mapped = f(v);
          if (mapped != v) r->SetRepeatedString(m, field, k, std::move(mapped));
        }
      } else if (r->HasField(*m, field) || !field->has_presence()) {
        const std::string& v = r->GetStringReference(*m, field, nullptr);
        std::string mapped = f(v);
        if (mapped != v) r->SetString(m, field, std::move(mapped));
      }
    } else if (type == google::protobuf::FieldDescriptor::TYPE_MESSAGE) {
      if (field->is_repeated()) {
        for (int k = 0; k < r->FieldSize(*m, field); ++k) {
          MapStrings(r->MutableRepeatedMessage(m, field, k), f);
        }
      } else if (r->HasField(*m, field)) {
        MapStrings(r->MutableMessage(m, field), f);
      }
    }
  }
}

}  // namespace

std::string EscapeUtf8(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size();) {
    const size_t n = IsEscape(text, i) ? 0 : Utf8Sequence(text, i);
    if (n == 0) {
      // Not UTF-8, or a code point of the escapes: each byte alone.
      const size_t bytes = IsEscape(text, i) ? 4 : 1;
      for (size_t k = 0; k < bytes; ++k)
        AppendEscape(static_cast<unsigned char>(text[i + k]), &out);
      i += bytes;
      continue;
    }
    out.append(text.substr(i, n));
    i += n;
  }
  return out;
}

std::string UnescapeUtf8(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size();) {
    if (IsEscape(text, i)) {
      const auto third = static_cast<unsigned char>(text[i + 2]);
      const auto fourth = static_cast<unsigned char>(text[i + 3]);
      out.push_back(char(((third - 0xBC) << 6) | (fourth & 0x3F)));
      i += 4;
    } else {
      out.push_back(text[i++]);
    }
  }
  return out;
}

std::string EncodeEnvelope(runtime::Envelope envelope) {
  envelope.set_version(kProtocolVersion);
  MapStrings(&envelope, [](std::string_view s) {
    // The common case (valid UTF-8, no escapes) without building a copy.
    for (size_t i = 0; i < s.size();) {
      const size_t n = IsEscape(s, i) ? 0 : Utf8Sequence(s, i);
      if (n == 0) return EscapeUtf8(s);
      i += n;
    }
    return std::string(s);
  });
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
  MapStrings(&envelope, [](std::string_view s) {
    return s.find('\xF4') == std::string_view::npos ? std::string(s) : UnescapeUtf8(s);
  });
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

bool SendWithin(zmq::socket_t* socket, std::string_view bytes, int timeout_ms) {
  const int before = socket->get(zmq::sockopt::sndtimeo);
  socket->set(zmq::sockopt::sndtimeo, timeout_ms);
  bool sent = false;
  try {
    sent = socket->send(zmq::buffer(bytes.data(), bytes.size()), zmq::send_flags::none).has_value();
  } catch (const zmq::error_t& e) {
    if (e.num() != EINTR) throw;
  }
  socket->set(zmq::sockopt::sndtimeo, before);
  return sent;
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
