// The wire layer of every dome socket (proto/runtime.proto and proto/capture.proto over
// ZeroMQ): one place that sets socket options (CURVE keys and the ZAP domain included,
// net/security.h), receives and sends multipart messages, frames runtime envelopes with
// the protocol version and the message size cap, and names peers for logs. dome-master,
// dome-worker, the dome client and the capture publisher and ingest (ingest/publish.h)
// all go through it.
//
// Framing: every message's payload is one frame holding a serialized Envelope. A
// ROUTER sees [routing id, payload] from DEALER peers and [routing id, empty,
// payload] from REQ peers. Nothing here asserts on network input: bad bytes, a wrong
// version or an oversized payload throw core::InputError naming the peer.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>
#include <zmq.hpp>

#include "runtime.pb.h"

namespace dome::net {

inline constexpr uint32_t kProtocolVersion = runtime::PROTOCOL_VERSION;

struct SocketOptions {
  // Largest payload accepted, in bytes; larger ones are refused with a log line. The
  // transport drops peers sending frames over twice this (ZMQ_MAXMSGSIZE).
  int64_t max_message_bytes = int64_t{256} << 20;
  // How long unsent messages are kept after close, in ms.
  int linger_ms = 0;
  // CURVE (net/security.h), all keys Z85. Empty keys: plaintext (the embedded cluster
  // over inproc://, or --insecure). A server socket (bound by the master) sets
  // secret_key only; a client socket (worker, dome client) sets server_key, the
  // master's public key, and its own public_key + secret_key.
  std::string public_key;
  std::string secret_key;
  std::string server_key;
  // The ZAP domain of CURVE server sockets (the ZAP handler sees it in each request):
  // the master sets each socket's role (net/security.h).
  std::string zap_domain = "dome";

  bool curve_server() const { return server_key.empty() && !secret_key.empty(); }
  bool curve_client() const { return !server_key.empty(); }
  // Throws core::InputError naming the first option out of range.
  void Check() const;
};

// Applies `options` to a socket before it binds or connects (every runtime socket goes
// through here): the one switch between CURVE server, CURVE client and plaintext.
void ConfigureSocket(zmq::socket_t* socket, const SocketOptions& options);

// The endpoint a socket actually bound (resolves "tcp://127.0.0.1:*" to the port).
std::string BoundEndpoint(const zmq::socket_t& socket);

// Text that is not UTF-8 on the wire. Protobuf `string` fields must be UTF-8, but a
// Linux path is any bytes (a take folder named with byte 0xE9) and an error may quote
// a file's bytes. EscapeUtf8 maps each byte that is not part of valid UTF-8 -- and each
// byte of a code point U+10FF00..U+10FFFF, so that the mapping stays one to one -- to
// the private-use code point U+10FF00 + byte; UnescapeUtf8 maps them back. Valid UTF-8
// without those code points passes through unchanged.
std::string EscapeUtf8(std::string_view text);
std::string UnescapeUtf8(std::string_view text);

// Serializes with the protocol version set; every string field, at any depth, through
// EscapeUtf8.
std::string EncodeEnvelope(runtime::Envelope envelope);

// Parses one payload, every string field through UnescapeUtf8 (the bytes the sender
// had). Throws core::InputError naming `peer` when it is over `max_bytes`, not an
// Envelope, of another protocol version, or has no body.
runtime::Envelope DecodeEnvelope(std::string_view bytes, const std::string& peer,
                                 int64_t max_bytes);

// A printable name for a ROUTER routing id, for logs and errors: "peer c07" when the id
// is printable text (capture agents name themselves by camera), else
// "peer 0x0080000001" (the ids ZeroMQ makes up for anonymous peers).
std::string PeerName(std::string_view routing_id);

// Sends a multipart message; false when the socket would block (peer gone, HWM).
bool SendFrames(zmq::socket_t* socket, std::initializer_list<std::string_view> frames);

// Sends one message, waiting at most timeout_ms for the socket to take it; false when
// it did not (or a signal cut the wait short). A send without a limit waits for good
// while the socket has no connection that takes messages: a client whose CURVE key the
// master refused is one (libzmq drops the connection's queue within milliseconds of the
// refusal, before the request went out if the client was slow to send it).
bool SendWithin(zmq::socket_t* socket, std::string_view bytes, int timeout_ms);

// Every part of the next message, received without blocking; empty when none waits.
std::vector<zmq::message_t> ReceiveFrames(zmq::socket_t* socket);

// Waits up to timeout_ms for a message on `socket`; false when none came in time or a
// signal cut the wait short (the caller's loop decides whether to go on).
bool WaitForInput(zmq::socket_t* socket, int timeout_ms);

}  // namespace dome::net
