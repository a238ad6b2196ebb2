// CURVE keys, allow-lists and the ZAP handler that secure the runtime's sockets
// (ZeroMQ RFC 26 CurveZMQ, RFC 27 ZAP).
//
// CURVE alone encrypts but lets in any client that knows the server's public key; the
// master therefore also runs a ZapHandler that accepts a CURVE client only when its
// public key is on the allow-list, and refuses NULL and PLAIN peers unless insecure.
//
// Key files (written by `dome keygen PREFIX`):
//   PREFIX.key  the secret key, Z85 (40 characters) on one line; mode 0600. A secret
//               key file that the group or others may read is refused.
//   PREFIX.pub  the public key, Z85 on one line; may be shared freely.
// Allow-list file: one Z85 public key and its roles a line, "KEY ROLE[,ROLE]" (a .pub
// file's line from `dome keygen PREFIX --role ROLE`), optionally followed by a
// `# name` comment; blank lines and other lines starting with # are ignored (Z85 itself
// uses '#': a line whose first word is a key is a key). Errors name FILE:LINE.
//
// Roles: `worker` (the master's worker socket: take jobs, read frames), `client` (the
// control and events sockets: submit, list, cancel, watch), `capture` (the capture
// socket: publish frames). Each server socket has its role as its ZAP domain; the
// handler admits a key on a socket only with that role.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>
#include <zmq.hpp>

namespace dome::net {

struct SocketOptions;  // net/wire.h

// A CURVE key pair, both keys Z85-encoded (40 characters each).
struct KeyPair {
  std::string public_key;
  std::string secret_key;
};

// A fresh key pair from libzmq (zmq_curve_keypair).
KeyPair GenerateKeyPair();

// The public key of a Z85 secret key (zmq_curve_public); throws InputError naming
// `where` when `secret_key` is not a Z85 key.
std::string PublicKeyOf(const std::string& secret_key, const std::string& where);

// True when `key` is 40 characters of Z85 that decode to 32 bytes.
bool IsZ85Key(const std::string& key);

// Writes PREFIX.key (mode 0600) and PREFIX.pub: the public key, then `roles`
// ("worker,client") when given, the allow-list's line. Throws InputError naming the
// file when either exists already (keys are never overwritten) or cannot be written.
void WriteKeyPair(const std::string& prefix, const KeyPair& keys, const std::string& roles = "");

// Reads a secret key file and derives its public key. Throws InputError naming the
// file when it is missing, readable by group or others, or holds no Z85 key.
KeyPair ReadSecretKeyFile(const std::filesystem::path& path);

// Reads a public key file (one Z85 key). Throws InputError naming the file.
std::string ReadPublicKeyFile(const std::filesystem::path& path);

inline constexpr const char* kRoleWorker = "worker";
inline constexpr const char* kRoleClient = "client";
inline constexpr const char* kRoleCapture = "capture";
bool IsRole(const std::string& role);

// Z85 public key -> the roles it is allowed.
using AllowList = std::map<std::string, std::set<std::string>>;

// Reads an allow-list. Throws InputError naming FILE:LINE for a line that is not a
// Z85 key with at least one known role, and the file when it is missing or lists no
// key.
AllowList ReadAllowList(const std::filesystem::path& path);

// The client side from the --master-key FILE (the master's .pub) and --key FILE (this
// side's .key) flags: sets socket->server_key, public_key and secret_key. With
// `insecure` (--insecure) and no files the socket stays plaintext. Throws InputError
// naming the missing or conflicting flag, or the unreadable file.
void ApplyClientKeys(const std::string& master_key_file, const std::string& key_file, bool insecure,
                     SocketOptions* socket);

// The master side from --keys DIR (DIR/master.key and DIR/allowed_keys), or
// --secret-key FILE and --allow FILE: sets socket->secret_key and returns the
// allow-list for the ZapHandler. With `insecure` and no keys: plaintext, an empty
// list. Throws InputError naming the missing or conflicting flag, or the bad file.
AllowList ApplyServerKeys(const std::string& keys_dir, const std::string& secret_key_file,
                          const std::string& allow_file, bool insecure, SocketOptions* socket);

// The ZAP handler of one ZeroMQ context: a REP socket bound to
// inproc://zeromq.zap.01, served on its own thread from construction to destruction.
// Every CURVE handshake on a server socket of that context asks it; NULL handshakes
// ask it only on sockets with a ZAP domain (net::ConfigureSocket sets one on every
// server socket). Refusals are logged (warn) with the peer's address and key.
class ZapHandler {
 public:
  // `allowed`: Z85 public keys let in, each on the sockets of its roles (the ZAP
  // domain). `allow_plaintext`: accept NULL peers on every socket (the --insecure
  // mode); PLAIN is always refused (dome never sends passwords).
  ZapHandler(zmq::context_t* context, AllowList allowed, bool allow_plaintext);
  ~ZapHandler();
  ZapHandler(const ZapHandler&) = delete;
  ZapHandler& operator=(const ZapHandler&) = delete;

  int64_t accepted() const;
  int64_t refused() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Logs the handshakes that fail on server sockets before the ZAP handler is asked,
// which ZeroMQ reports only to a socket monitor: a plaintext peer on a CURVE socket
// (mechanism mismatch), a peer encrypting to another server key, a malformed greeting.
// One thread reads the monitors of `sockets` (each with its name for the log, e.g.
// "worker") from construction to destruction; lines are throttled per socket and cause
// like the ZAP handler's. The sockets must outlive it. With `client`, the sockets are
// a worker's or client's connections to the master, and the master refusing this
// side's key (ZAP) is logged too, as an error naming the master: otherwise the side
// sees only silence.
class HandshakeLog {
 public:
  HandshakeLog(zmq::context_t* context,
               const std::vector<std::pair<zmq::socket_t*, std::string>>& sockets,
               bool client = false);
  ~HandshakeLog();
  HandshakeLog(const HandshakeLog&) = delete;
  HandshakeLog& operator=(const HandshakeLog&) = delete;

  int64_t failures() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dome::net
