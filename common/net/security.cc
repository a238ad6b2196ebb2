#include "net/security.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zmq.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <thread>
#include <vector>

#include "core/error.h"
#include "core/wake_pipe.h"
#include "net/log_throttle.h"
#include "net/wire.h"
#include "spdlog/spdlog.h"

namespace dome::net {
namespace fs = std::filesystem;

namespace {

constexpr size_t kZ85KeyChars = 40;

// Splits a key-file line into its first word and the rest before a comment. Z85 uses
// '#', so a line is a comment only when its first word is not a key and starts with
// '#'; after a key, roles and a comment may follow. Returns "" for blank and comment
// lines.
std::string KeyToken(const std::string& line, std::string* rest) {
  std::istringstream in(line);
  std::string token;
  in >> token;
  std::string more;
  std::getline(in, more);
  // After the key: its roles (words without '#'), then perhaps a comment.
  more = more.substr(0, more.find('#'));
  more.erase(0, more.find_first_not_of(" \t\r"));
  if (rest) *rest = more;
  if (!IsZ85Key(token) && !token.empty() && token[0] == '#') return "";
  return token;
}

std::string ReadText(const fs::path& path, const std::string& what) {
  std::ifstream in(path);
  if (!in) {
    throw core::InputError(path.string(),
                           "cannot read the " + what + " (" + std::strerror(errno) + ")");
  }
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The keys of a key file, each with its line number; blank and comment lines are
// skipped. A line that is not one Z85 key (plus an optional comment) is named
// FILE:LINE with `expected`.
struct KeyLine {
  std::string key;
  std::string rest;  // what follows the key before a comment: its roles
  int line = 0;
};
std::vector<KeyLine> ReadKeyLines(const fs::path& path, const std::string& what,
                                  const std::string& expected) {
  std::istringstream in(ReadText(path, what));
  std::vector<KeyLine> keys;
  std::string line;
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    std::string rest;
    const std::string token = KeyToken(line, &rest);
    if (token.empty()) continue;
    core::Require(IsZ85Key(token), path.string() + ":" + std::to_string(line_no), expected);
    const auto end = rest.find_last_not_of(" \t\r");
    keys.push_back({token, end == std::string::npos ? "" : rest.substr(0, end + 1), line_no});
  }
  return keys;
}

// "worker,client" -> {worker, client}; throws naming `where` for an unknown role.
std::set<std::string> ParseRoles(const std::string& text, const std::string& where) {
  std::set<std::string> roles;
  std::string word;
  std::istringstream in(text);
  while (std::getline(in, word, ',')) {
    word.erase(0, word.find_first_not_of(" \t"));
    word.erase(word.find_last_not_of(" \t") + 1);
    if (word.empty()) continue;
    core::Require(IsRole(word), where,
                  "unknown role '" + word.substr(0, 40) + "'; expected worker, client or capture");
    roles.insert(word);
  }
  return roles;
}

// The single key of a key file (comment lines allowed).
std::string ReadSingleKey(const fs::path& path, const std::string& what) {
  const auto keys = ReadKeyLines(
      path, what, "expected a Z85 CURVE key (40 characters, as written by `dome keygen`)");
  core::Require(!keys.empty(), path.string(), "holds no key; expected the " + what);
  core::Require(keys.size() == 1, path.string() + ":" + std::to_string(keys[1].line),
                "a second key; a " + what + " holds one Z85 key");
  // A .pub line may name the key's roles (dome keygen --role): checked, not needed here.
  ParseRoles(keys[0].rest, path.string() + ":" + std::to_string(keys[0].line));
  return keys[0].key;
}

std::string Z85(const uint8_t* bytes32) {
  char text[kZ85KeyChars + 1];
  zmq_z85_encode(text, bytes32, 32);
  return text;
}

}  // namespace

KeyPair GenerateKeyPair() {
  char pub[kZ85KeyChars + 1], sec[kZ85KeyChars + 1];
  if (zmq_curve_keypair(pub, sec) != 0) {
    throw core::InputError("zmq_curve_keypair",
                           std::string("libzmq cannot make CURVE keys: ") + zmq_strerror(errno));
  }
  return {pub, sec};
}

bool IsZ85Key(const std::string& key) {
  if (key.size() != kZ85KeyChars) return false;
  uint8_t bytes[32];
  return zmq_z85_decode(bytes, key.c_str()) != nullptr;
}

std::string PublicKeyOf(const std::string& secret_key, const std::string& where) {
  core::Require(IsZ85Key(secret_key), where, "expected a Z85 CURVE secret key (40 characters)");
  char pub[kZ85KeyChars + 1];
  if (zmq_curve_public(pub, secret_key.c_str()) != 0) {
    throw core::InputError(where,
                           std::string("cannot derive the public key: ") + zmq_strerror(errno));
  }
  return pub;
}

void WriteKeyPair(const std::string& prefix, const KeyPair& keys, const std::string& roles) {
  const std::string secret = prefix + ".key", pub = prefix + ".pub";
  for (const auto& f : {secret, pub}) {
    core::Require(!fs::exists(f), f,
                  "exists already; keys are never overwritten (remove it first)");
  }
  auto write = [](const std::string& path, const std::string& text, mode_t mode) {
    // O_EXCL: never replace a file that appeared meanwhile; the mode is set at creation
    // so the secret is never readable by others, not even for a moment.
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL, mode);
    if (fd < 0) throw core::InputError(path, std::string("cannot create: ") + std::strerror(errno));
    const bool ok = ::write(fd, text.data(), text.size()) == ssize_t(text.size()) &&
                    ::fchmod(fd, mode) == 0 && ::fsync(fd) == 0;
    ::close(fd);
    if (!ok) throw core::InputError(path, std::string("cannot write: ") + std::strerror(errno));
  };
  write(secret, keys.secret_key + "\n", 0600);
  write(pub, keys.public_key + (roles.empty() ? "" : " " + roles) + "\n", 0644);
}

KeyPair ReadSecretKeyFile(const fs::path& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    throw core::InputError(path.string(), std::string("cannot read the secret key file (") +
                                              std::strerror(errno) + ")");
  }
  if ((st.st_mode & 077) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", unsigned(st.st_mode & 07777));
    throw core::InputError(path.string(),
                           std::string("secret key file has mode ") + mode +
                               ": the group or others may read it; allow only its owner "
                               "(chmod 600)");
  }
  KeyPair keys;
  keys.secret_key = ReadSingleKey(path, "secret key file");
  keys.public_key = PublicKeyOf(keys.secret_key, path.string());
  return keys;
}

std::string ReadPublicKeyFile(const fs::path& path) {
  return ReadSingleKey(path, "public key file");
}

bool IsRole(const std::string& role) {
  return role == kRoleWorker || role == kRoleClient || role == kRoleCapture;
}

AllowList ReadAllowList(const fs::path& path) {
  AllowList keys;
  for (const auto& k :
       ReadKeyLines(path, "allow-list",
                    "expected a Z85 CURVE public key (40 characters) and its roles a line "
                    "(a .pub file's line from `dome keygen PREFIX --role ROLE`), optionally "
                    "followed by '# comment'")) {
    const std::string where = path.string() + ":" + std::to_string(k.line);
    std::set<std::string> roles = ParseRoles(k.rest, where);
    // A key without roles used to be let in everywhere: a worker's key could submit and
    // cancel, a client's could take jobs. Each key now says what it may do.
    core::Require(!roles.empty(), where,
                  "the key names no role; expected 'KEY ROLE[,ROLE]' with roles worker, "
                  "client or capture (dome keygen PREFIX --role ROLE writes such a .pub)");
    keys[k.key].insert(roles.begin(), roles.end());
  }
  core::Require(!keys.empty(), path.string(),
                "lists no public key; nobody could connect (add the workers' and clients' .pub "
                "lines)");
  return keys;
}

void ApplyClientKeys(const std::string& master_key_file, const std::string& key_file, bool insecure,
                     SocketOptions* socket) {
  const bool any = !master_key_file.empty() || !key_file.empty();
  if (insecure) {
    core::Require(!any, "--insecure", "conflicts with --master-key and --key (choose one)");
    return;
  }
  const std::string why =
      " (a secure master admits only CURVE clients whose key it allows; make keys with "
      "`dome keygen PREFIX`), or --insecure for a master started with --insecure";
  core::Require(
      !master_key_file.empty(), "--master-key",
      "missing: give the master's public key file (its .pub) with --master-key FILE" + why);
  core::Require(!key_file.empty(), "--key",
                "missing: give this side's secret key file (a .key whose .pub is on the "
                "master's allow-list) with --key FILE" +
                    why);
  socket->server_key = ReadPublicKeyFile(master_key_file);
  const KeyPair own = ReadSecretKeyFile(key_file);
  socket->public_key = own.public_key;
  socket->secret_key = own.secret_key;
}

AllowList ApplyServerKeys(const std::string& keys_dir, const std::string& secret_key_file,
                          const std::string& allow_file, bool insecure, SocketOptions* socket) {
  const bool any = !keys_dir.empty() || !secret_key_file.empty() || !allow_file.empty();
  if (insecure) {
    core::Require(!any, "--insecure", "conflicts with --keys, --secret-key and --allow (choose)");
    return {};
  }
  std::string secret = secret_key_file, allow = allow_file;
  if (!keys_dir.empty()) {
    core::Require(secret.empty() && allow.empty(), "--keys",
                  "conflicts with --secret-key and --allow (--keys DIR means DIR/master.key and "
                  "DIR/allowed_keys)");
    secret = (fs::path(keys_dir) / "master.key").string();
    allow = (fs::path(keys_dir) / "allowed_keys").string();
  }
  const std::string how =
      "--keys DIR (DIR/master.key and DIR/allowed_keys), or --secret-key FILE and --allow "
      "FILE (make keys with `dome keygen PREFIX`), or --insecure for plaintext";
  core::Require(!secret.empty() || !allow.empty(), "--keys", "missing: no keys given; give " + how);
  core::Require(!secret.empty(), "--secret-key",
                "missing: the master's secret key file; give " + how);
  core::Require(!allow.empty(), "--allow",
                "missing: the allow-list of worker and client public keys; give " + how);
  socket->secret_key = ReadSecretKeyFile(secret).secret_key;
  socket->public_key.clear();
  socket->server_key.clear();
  return ReadAllowList(allow);
}

// ---- ZAP ---------------------------------------------------------------------------

struct ZapHandler::Impl {
  zmq::socket_t socket;
  AllowList allowed;
  bool allow_plaintext;
  std::atomic<bool> stop{false};
  std::atomic<int64_t> accepted{0}, refused{0};
  std::thread thread;
  LogThrottle throttle;  // per peer and key

  Impl(zmq::context_t* context, AllowList keys, bool plaintext)
      : socket(*context, zmq::socket_type::rep),
        allowed(std::move(keys)),
        allow_plaintext(plaintext) {
    socket.set(zmq::sockopt::linger, 0);
    try {
      socket.bind("inproc://zeromq.zap.01");
    } catch (const zmq::error_t& e) {
      throw core::InputError("inproc://zeromq.zap.01",
                             std::string("cannot start the ZAP handler: ") + e.what());
    }
  }

  void Serve() {
    while (!stop) {
      zmq::pollitem_t items[] = {{socket.handle(), 0, ZMQ_POLLIN, 0}};
      zmq::poll(items, 1, std::chrono::milliseconds(50));
      if (!(items[0].revents & ZMQ_POLLIN)) continue;
      std::vector<zmq::message_t> frames;
      while (true) {
        zmq::message_t m;
        if (!socket.recv(m, zmq::recv_flags::dontwait)) break;
        const bool more = m.more();
        frames.push_back(std::move(m));
        if (!more) break;
      }
      if (!frames.empty()) Answer(frames);  // REP: answer only what was received
    }
  }

  // RFC 27: version, request id, domain, address, identity, mechanism, credentials...
  void Answer(const std::vector<zmq::message_t>& f) {
    std::string request_id = f.size() > 1 ? f[1].to_string() : "";
    std::string code = "400", text;
    if (f.size() < 6 || f[0].to_string_view() != "1.0") {
      text = "malformed ZAP request";
      spdlog::warn("ZAP: malformed request of {} frames refused", f.size());
    } else {
      const std::string domain = f[2].to_string(), address = f[3].to_string(),
                        mechanism = f[5].to_string();
      if (mechanism == "CURVE" && f.size() == 7 && f[6].size() == 32) {
        const std::string key = Z85(static_cast<const uint8_t*>(f[6].data()));
        auto it = allowed.find(key);
        if (it != allowed.end() && it->second.count(domain)) {
          code = "200";
          text = "OK";
          spdlog::debug("ZAP: CURVE client {} from {} accepted as {}", key, address, domain);
        } else if (it != allowed.end()) {
          text = "public key not allowed the role " + domain;
          if (auto n = throttle.ShouldLog(address + " " + key + " " + domain)) {
            std::string roles;
            for (const auto& r : it->second) roles += (roles.empty() ? "" : ",") + r;
            spdlog::warn(
                "refused CURVE client from {} on the {} socket: public key {} is allowed only "
                "as {}{}",
                address, domain, key, roles, LogThrottle::Repeats(*n));
          }
        } else {
          text = "public key not on the allow-list";
          if (auto n = throttle.ShouldLog(address + " " + key)) {
            spdlog::warn("refused CURVE client from {}: public key {} is not on the allow-list{}",
                         address, key, LogThrottle::Repeats(*n));
          }
        }
      } else if (mechanism == "NULL" && allow_plaintext) {
        code = "200";
        text = "OK";
      } else {
        text = "mechanism " + mechanism + " not allowed";
        if (auto n = throttle.ShouldLog(address + " " + mechanism)) {
          spdlog::warn("refused {} client from {}: only CURVE clients with allowed keys{}",
                       mechanism, address, LogThrottle::Repeats(*n));
        }
      }
    }
    (code == "200" ? accepted : refused)++;
    const std::string user = code == "200" ? "dome" : "";
    const std::string reply[] = {"1.0", request_id, code, text, user, ""};
    for (size_t i = 0; i < 6; ++i) {
      socket.send(zmq::buffer(reply[i]),
                  i + 1 < 6 ? zmq::send_flags::sndmore : zmq::send_flags::none);
    }
  }
};

ZapHandler::ZapHandler(zmq::context_t* context, AllowList allowed, bool allow_plaintext)
    : impl_(std::make_unique<Impl>(context, std::move(allowed), allow_plaintext)) {
  impl_->thread = std::thread([this] { impl_->Serve(); });
}

ZapHandler::~ZapHandler() {
  impl_->stop = true;
  impl_->thread.join();
}

int64_t ZapHandler::accepted() const { return impl_->accepted; }
int64_t ZapHandler::refused() const { return impl_->refused; }

// ---- handshake failures --------------------------------------------------------------

namespace {

// Why a handshake failed, from a monitor event and its value (zmq_socket_monitor(3)).
std::string HandshakeFailure(uint16_t event, uint32_t value) {
  if (event == ZMQ_EVENT_HANDSHAKE_FAILED_AUTH) {
    return "it refused this side's public key (ZAP status " + std::to_string(value) +
           "): the key is not on the master's allow-list, or not with the role of the socket "
           "it connects to (worker, client or capture; `dome keygen --role`)";
  }
  if (event == ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL) {
    if (value == ZMQ_PROTOCOL_ERROR_ZMTP_MECHANISM_MISMATCH) {
      return "the peer speaks another security mechanism (plaintext against CURVE or the "
             "reverse: check its --master-key and --insecure flags against the master's)";
    }
    if (value == ZMQ_PROTOCOL_ERROR_ZMTP_CRYPTOGRAPHIC) {
      return "the peer's CURVE handshake does not decrypt (it encrypts to another master "
             "public key, or its messages are corrupt)";
    }
    char hex[16];
    std::snprintf(hex, sizeof hex, "0x%08x", unsigned(value));
    return std::string("ZMTP protocol error ") + hex + " (a malformed greeting or handshake)";
  }
  // Which side notices a mismatch first is a race: the peer may hang up before this
  // side reads its greeting.
  return std::string("the handshake broke off (") + std::strerror(int(value)) +
         "): a peer with another security mechanism or key, or one that went away";
}

}  // namespace

struct HandshakeLog::Impl {
  struct Watched {
    zmq::socket_t* socket;
    std::string name;
    zmq::socket_t monitor;  // PAIR, connected to the socket's monitor endpoint
  };
  std::vector<Watched> watched;
  std::atomic<bool> stop{false};
  std::atomic<int64_t> failures{0};
  LogThrottle throttle;
  bool client = false;
  // Woken by the destructor, polled by Serve: the thread stops at once instead of at
  // the end of its poll (50 ms at every master's and `dome run`'s exit).
  core::WakePipe stopping{"handshake log"};
  std::thread thread;

  void Serve() {
    while (!stop) {
      std::vector<zmq::pollitem_t> items;
      for (auto& w : watched) items.push_back({w.monitor.handle(), 0, ZMQ_POLLIN, 0});
      items.push_back({nullptr, stopping.read_fd(), ZMQ_POLLIN, 0});
      zmq::poll(items, std::chrono::milliseconds(50));
      for (size_t i = 0; i < watched.size(); ++i) {
        if (items[i].revents & ZMQ_POLLIN) Read(&watched[i]);
      }
    }
  }

  // One event: a frame of 6 bytes (event id, value), then a frame with the endpoint.
  void Read(Watched* w) {
    zmq::message_t head, address;
    while (w->monitor.recv(head, zmq::recv_flags::dontwait)) {
      if (!head.more() || !w->monitor.recv(address, zmq::recv_flags::dontwait)) continue;
      if (head.size() != 6) continue;
      uint16_t event;
      uint32_t value;
      std::memcpy(&event, head.data(), 2);
      std::memcpy(&value, static_cast<const char*>(head.data()) + 2, 4);
      ++failures;
      const std::string why = HandshakeFailure(event, value);
      if (auto n = throttle.ShouldLog(w->name + " " + why)) {
        if (client) {
          spdlog::error("the master at {} refused this {}: {}{}", address.to_string(), w->name, why,
                        LogThrottle::Repeats(*n));
        } else {
          spdlog::warn("refused a peer on the {} socket ({}): {}{}", w->name, address.to_string(),
                       why, LogThrottle::Repeats(*n));
        }
      }
    }
  }
};

HandshakeLog::HandshakeLog(zmq::context_t* context,
                           const std::vector<std::pair<zmq::socket_t*, std::string>>& sockets,
                           bool client)
    : impl_(std::make_unique<Impl>()) {
  impl_->client = client;
  // Server side: failures the ZAP handler refuses are logged by it; these come before
  // it is asked. Client side: its refusal too, which nothing else reports.
  const int events = ZMQ_EVENT_HANDSHAKE_FAILED_NO_DETAIL | ZMQ_EVENT_HANDSHAKE_FAILED_PROTOCOL |
                     (client ? ZMQ_EVENT_HANDSHAKE_FAILED_AUTH : 0);
  static std::atomic<uint64_t> serial{0};
  for (const auto& [socket, name] : sockets) {
    char endpoint[96];
    std::snprintf(endpoint, sizeof endpoint, "inproc://dome.handshake.%p.%llu", socket->handle(),
                  (unsigned long long)serial++);
    if (zmq_socket_monitor(socket->handle(), endpoint, events) != 0) {
      throw core::InputError(
          name + " socket", std::string("cannot monitor handshakes: ") + zmq_strerror(zmq_errno()));
    }
    Impl::Watched w{socket, name, zmq::socket_t(*context, zmq::socket_type::pair)};
    w.monitor.set(zmq::sockopt::linger, 0);
    w.monitor.connect(endpoint);
    impl_->watched.push_back(std::move(w));
  }
  impl_->thread = std::thread([this] { impl_->Serve(); });
}

HandshakeLog::~HandshakeLog() {
  impl_->stop = true;
  impl_->stopping.Wake();
  impl_->thread.join();
  for (auto& w : impl_->watched) zmq_socket_monitor(w.socket->handle(), nullptr, 0);
}

int64_t HandshakeLog::failures() const { return impl_->failures; }

}  // namespace dome::net
