#include "capture/sony9pin.h"

#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

#include "core/error.h"

namespace dome::capture {
namespace {

constexpr uint8_t kNakUndefined = 0x01, kNakChecksum = 0x04, kNakParity = 0x10, kNakOverrun = 0x20,
                  kNakFraming = 0x40, kNakTimeout = 0x80;

uint8_t Bcd(int v) { return static_cast<uint8_t>(((v / 10) << 4) | (v % 10)); }
std::optional<int> FromBcd(uint8_t b, uint8_t tens_mask) {
  const int lo = b & 0x0F, hi = (b >> 4) & tens_mask;
  if (lo > 9) return std::nullopt;
  return hi * 10 + lo;
}

void SleepMs(int ms) { std::this_thread::sleep_for(std::chrono::milliseconds(ms)); }

}  // namespace

uint8_t Sony9PinChecksum(const uint8_t* bytes, size_t n) {
  unsigned sum = 0;
  for (size_t i = 0; i < n; ++i) sum += bytes[i];
  return static_cast<uint8_t>(sum & 0xFF);
}

std::vector<uint8_t> Sony9PinBlock::Encode() const {
  DOME_CHECK(data.size() <= 15, "at most 15 data bytes");
  std::vector<uint8_t> bytes{static_cast<uint8_t>((cmd1 & 0xF0) | data.size()), cmd2};
  bytes.insert(bytes.end(), data.begin(), data.end());
  bytes.push_back(Sony9PinChecksum(bytes.data(), bytes.size()));
  return bytes;
}

std::vector<uint8_t> EncodeTimeData(const take::Timecode& tc, bool drop_frame) {
  return {static_cast<uint8_t>(Bcd(tc.frames) | (drop_frame ? 0x40 : 0)), Bcd(tc.seconds),
          Bcd(tc.minutes), Bcd(tc.hours)};
}

std::optional<take::Timecode> DecodeTimeData(const uint8_t* data) {
  const auto f = FromBcd(data[0], 0x3), s = FromBcd(data[1], 0x7), m = FromBcd(data[2], 0x7),
             h = FromBcd(data[3], 0x3);
  if (!f || !s || !m || !h || *s > 59 || *m > 59 || *h > 23 || *f > 29) return std::nullopt;
  return take::Timecode{*h, *m, *s, *f};
}

std::string NakText(uint8_t error) {
  std::string text;
  auto add = [&](uint8_t bit, const char* name) {
    if (!(error & bit)) return;
    if (!text.empty()) text += ", ";
    text += name;
  };
  add(kNakUndefined, "undefined command");
  add(kNakChecksum, "checksum error");
  add(kNakParity, "parity error");
  add(kNakOverrun, "buffer overrun");
  add(kNakFraming, "framing error");
  add(kNakTimeout, "time-out");
  return text.empty() ? "unspecified error" : text;
}

// --- serial port -------------------------------------------------------------------

SerialPort::SerialPort(const std::string& device) : device_(device) {
  const std::string where = "serial:" + device;
  fd_ = ::open(device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  core::Require(fd_ >= 0, where,
                std::string("cannot open the serial port: ") + std::strerror(errno));
  termios tio{};
  if (::tcgetattr(fd_, &tio) != 0) {
    const int e = errno;
    ::close(fd_);
    throw core::InputError(where,
                           std::string("not a serial port (tcgetattr: ") + std::strerror(e) + ")");
  }
  ::cfmakeraw(&tio);
  ::cfsetispeed(&tio, B38400);
  ::cfsetospeed(&tio, B38400);
  tio.c_cflag &= ~(CSIZE | CSTOPB | CRTSCTS);
  tio.c_cflag |= CS8 | PARENB | PARODD | CLOCAL | CREAD;  // 8 data bits, odd parity, 1 stop bit
  tio.c_iflag |= INPCK;                                   // check parity on input
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  if (::tcsetattr(fd_, TCSANOW, &tio) != 0) {
    const int e = errno;
    ::close(fd_);
    throw core::InputError(where,
                           std::string("cannot set 38400 8O1 raw mode: ") + std::strerror(e));
  }
  ::tcflush(fd_, TCIOFLUSH);
}

SerialPort::~SerialPort() {
  if (fd_ >= 0) ::close(fd_);
}

void SerialPort::Write(const std::vector<uint8_t>& bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
    if (n < 0 && (errno == EAGAIN || errno == EINTR)) {
      pollfd p{fd_, POLLOUT, 0};
      ::poll(&p, 1, 10);
      continue;
    }
    core::Require(n > 0, "serial:" + device_, std::string("write failed: ") + std::strerror(errno));
    done += static_cast<size_t>(n);
  }
}

std::vector<uint8_t> SerialPort::Read(size_t n, int timeout_ms) {
  std::vector<uint8_t> out;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (out.size() < n) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                          deadline - std::chrono::steady_clock::now())
                          .count();
    if (left <= 0) break;
    pollfd p{fd_, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(left));
    if (ready <= 0) continue;
    uint8_t buf[64];
    const ssize_t got = ::read(fd_, buf, std::min(sizeof buf, n - out.size()));
    if (got > 0) out.insert(out.end(), buf, buf + got);
    if (got < 0 && errno != EAGAIN && errno != EINTR) break;
    if (got == 0) SleepMs(1);  // hang-up on a pseudo-terminal: wait out the time-out
  }
  return out;
}

void SerialPort::Flush() { ::tcflush(fd_, TCIFLUSH); }

// --- controller ----------------------------------------------------------------------

void Sony9PinOptions::Check() const {
  core::Require(reply_timeout_ms > 0, "reply_timeout_ms",
                "must be positive, got " + std::to_string(reply_timeout_ms));
  core::Require(retries >= 1, "retries", "must be at least 1, got " + std::to_string(retries));
  core::Require(retry_delay_ms >= 0, "retry_delay_ms", "must not be negative");
}

void DeckEmulatorOptions::Check() const {
  core::Require(nak_first >= 0, "nak_first",
                "must not be negative, got " + std::to_string(nak_first));
}

Sony9PinDeck::Sony9PinDeck(const std::string& device, const Sony9PinOptions& options)
    : port_(device), options_(options) {
  options.Check();
}

std::optional<Sony9PinBlock> Sony9PinDeck::ReadReply(int timeout_ms) {
  const std::vector<uint8_t> head = port_.Read(2, timeout_ms);
  if (head.size() < 2) return std::nullopt;
  const size_t count = head[0] & 0x0F;
  // The rest of a block follows within the protocol's 10 ms between bytes.
  const std::vector<uint8_t> rest = port_.Read(count + 1, 20 + 2 * static_cast<int>(count));
  if (rest.size() < count + 1) return std::nullopt;
  std::vector<uint8_t> all = head;
  all.insert(all.end(), rest.begin(), rest.end());
  if (Sony9PinChecksum(all.data(), all.size() - 1) != all.back()) {
    Sony9PinBlock bad;  // a reply that failed its checksum: reported as a NAK of ours
    bad.cmd1 = 0x10;
    bad.cmd2 = 0x12;
    bad.data = {kNakChecksum};
    return bad;
  }
  Sony9PinBlock reply;
  reply.cmd1 = all[0] & 0xF0;
  reply.cmd2 = all[1];
  reply.data.assign(all.begin() + 2, all.end() - 1);
  return reply;
}

Sony9PinBlock Sony9PinDeck::Transact(const Sony9PinBlock& block, const std::string& what) {
  std::string last_problem;
  int tries = 0;
  for (int attempt = 0; attempt < options_.retries; ++attempt) {
    ++tries;
    if (attempt > 0) SleepMs(options_.retry_delay_ms);
    port_.Flush();
    port_.Write(block.Encode());
    const auto reply = ReadReply(options_.reply_timeout_ms);
    if (!reply) {
      last_problem = "no reply within " + std::to_string(options_.reply_timeout_ms) + " ms";
      continue;
    }
    if (reply->cmd1 == 0x10 && reply->cmd2 == 0x12) {
      const uint8_t error = reply->data.empty() ? 0 : reply->data[0];
      last_problem = "NAK (" + NakText(error) + ")";
      if (error & kNakUndefined) break;  // retrying cannot help
      continue;
    }
    return *reply;
  }
  throw core::InputError(Name(), what + " failed after " + std::to_string(tries) +
                                     (tries == 1 ? " try: " : " tries: ") + last_problem +
                                     "; expected a Sony 9-pin deck in remote mode answering at "
                                     "38400 baud 8O1");
}

void Sony9PinDeck::Command(uint8_t cmd1, uint8_t cmd2, const std::vector<uint8_t>& data,
                           const std::string& what) {
  const Sony9PinBlock reply = Transact({cmd1, cmd2, data}, what);
  core::Require(reply.cmd1 == 0x10 && reply.cmd2 == 0x01, Name(),
                what + ": expected ACK (10 01), got a block " + std::to_string(reply.cmd1) + " " +
                    std::to_string(reply.cmd2));
}

void Sony9PinDeck::Play() { Command(0x20, 0x01, {}, "PLAY"); }
void Sony9PinDeck::Stop() { Command(0x20, 0x00, {}, "STOP"); }
void Sony9PinDeck::FastForward() { Command(0x20, 0x10, {}, "FAST FWD"); }
void Sony9PinDeck::Rewind() { Command(0x20, 0x20, {}, "REWIND"); }

void Sony9PinDeck::CueUpWithData(const take::Timecode& tc) {
  Command(0x20, 0x31, EncodeTimeData(tc, options_.drop_frame), "CUE UP WITH DATA " + tc.Text());
}

take::Timecode Sony9PinDeck::CurrentTime() {
  const Sony9PinBlock reply = Transact({0x60, 0x0C, {0x02}}, "CURRENT TIME SENSE");
  core::Require(
      reply.cmd1 == 0x70 && (reply.cmd2 == 0x06 || reply.cmd2 == 0x04) && reply.data.size() == 4,
      Name(), "CURRENT TIME SENSE: expected a time data reply (74 06 + 4 bytes)");
  const auto tc = DecodeTimeData(reply.data.data());
  core::Require(tc.has_value(), Name(), "CURRENT TIME SENSE: the reply's time is not valid BCD");
  return *tc;
}

DeckStatus Sony9PinDeck::Status() {
  const Sony9PinBlock reply = Transact({0x60, 0x20, {0x04}}, "STATUS SENSE");
  core::Require(reply.cmd1 == 0x70 && reply.cmd2 == 0x20 && reply.data.size() >= 3, Name(),
                "STATUS SENSE: expected a status reply (7x 20 + status bytes)");
  DeckStatus status;
  status.tape_loaded = !(reply.data[0] & 0x20);
  const uint8_t t = reply.data[1];
  status.transport = (t & 0x01)   ? Transport::kPlaying
                     : (t & 0x04) ? Transport::kFastForward
                     : (t & 0x08) ? Transport::kRewind
                                  : Transport::kStopped;
  status.cue_complete = reply.data[2] & 0x01;
  return status;
}

// --- emulator ------------------------------------------------------------------------

DeckEmulator::DeckEmulator(Deck* deck, const DeckEmulatorOptions& options)
    : deck_(deck), options_(options) {
  options.Check();
  master_fd_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
  core::Require(master_fd_ >= 0, "pseudo-terminal",
                std::string("posix_openpt: ") + std::strerror(errno));
  core::Require(::grantpt(master_fd_) == 0 && ::unlockpt(master_fd_) == 0, "pseudo-terminal",
                std::string("grantpt/unlockpt: ") + std::strerror(errno));
  char name[128];
  core::Require(::ptsname_r(master_fd_, name, sizeof name) == 0, "pseudo-terminal",
                "ptsname failed");
  slave_path_ = name;
  // Raw mode on the line before any controller opens it, and one descriptor held open
  // so the pair survives a controller closing and reopening it.
  slave_keep_fd_ = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
  core::Require(slave_keep_fd_ >= 0, slave_path_, std::string("open: ") + std::strerror(errno));
  termios tio{};
  ::tcgetattr(slave_keep_fd_, &tio);
  ::cfmakeraw(&tio);
  ::tcsetattr(slave_keep_fd_, TCSANOW, &tio);
}

DeckEmulator::~DeckEmulator() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (slave_keep_fd_ >= 0) ::close(slave_keep_fd_);
  if (master_fd_ >= 0) ::close(master_fd_);
}

void DeckEmulator::Start() {
  thread_ = std::thread([this] { Serve(); });
}

void DeckEmulator::Serve() {
  std::vector<uint8_t> pending;
  auto last_byte = std::chrono::steady_clock::now();
  while (!stop_) {
    pollfd p{master_fd_, POLLIN, 0};
    if (::poll(&p, 1, 20) > 0 && (p.revents & POLLIN)) {
      uint8_t buf[64];
      const ssize_t n = ::read(master_fd_, buf, sizeof buf);
      if (n > 0) {
        // A gap of over 10 ms between bytes starts a new block (the protocol's rule).
        const auto now = std::chrono::steady_clock::now();
        if (now - last_byte > std::chrono::milliseconds(10)) pending.clear();
        last_byte = now;
        pending.insert(pending.end(), buf, buf + n);
      }
    }
    while (pending.size() >= 2 && pending.size() >= 3 + static_cast<size_t>(pending[0] & 0x0F)) {
      const size_t size = 3 + (pending[0] & 0x0F);
      std::vector<uint8_t> block(pending.begin(), pending.begin() + static_cast<long>(size));
      pending.erase(pending.begin(), pending.begin() + static_cast<long>(size));
      const int index = commands_++;
      if (options_.silent_after >= 0 && index >= options_.silent_after) continue;
      const std::vector<uint8_t> reply = Answer(block);
      if (!reply.empty() && ::write(master_fd_, reply.data(), reply.size()) < 0) return;
    }
  }
}

std::vector<uint8_t> DeckEmulator::Answer(const std::vector<uint8_t>& block) {
  auto nak = [](uint8_t error) { return Sony9PinBlock{0x10, 0x12, {error}}.Encode(); };
  const std::vector<uint8_t> ack = Sony9PinBlock{0x10, 0x01, {}}.Encode();
  if (Sony9PinChecksum(block.data(), block.size() - 1) != block.back()) return nak(kNakChecksum);
  if (options_.nak_everything) return nak(kNakUndefined);
  if (commands_.load() <= options_.nak_first) return nak(kNakChecksum);
  const uint8_t group = block[0] & 0xF0, cmd = block[1];
  const uint8_t* data = block.data() + 2;
  const size_t count = block[0] & 0x0F;
  try {
    if (group == 0x20 && cmd == 0x00) {
      deck_->Stop();
    } else if (group == 0x20 && cmd == 0x01) {
      deck_->Play();
    } else if (group == 0x20 && cmd == 0x10) {
      deck_->FastForward();
    } else if (group == 0x20 && cmd == 0x20) {
      deck_->Rewind();
    } else if (group == 0x20 && cmd == 0x31 && count == 4) {
      const auto tc = DecodeTimeData(data);
      if (!tc) return nak(kNakUndefined);
      deck_->CueUpWithData(*tc);
    } else if (group == 0x60 && cmd == 0x0C && count == 1) {
      const take::Timecode tc = deck_->CurrentTime();
      return Sony9PinBlock{0x70, 0x06, EncodeTimeData(tc, false)}.Encode();
    } else if (group == 0x60 && cmd == 0x20 && count == 1) {
      const DeckStatus s = deck_->Status();
      std::vector<uint8_t> bytes(std::max(3, data[0] & 0x0F), 0);
      if (!s.tape_loaded) bytes[0] |= 0x20;
      switch (s.transport) {
        case Transport::kPlaying:
          bytes[1] |= 0x01;
          break;
        case Transport::kFastForward:
          bytes[1] |= 0x04;
          break;
        case Transport::kRewind:
          bytes[1] |= 0x08;
          break;
        case Transport::kStopped:
          bytes[1] |= 0x20;
          break;
      }
      if (s.cue_complete) bytes[2] |= 0x01;
      return Sony9PinBlock{0x70, 0x20, bytes}.Encode();
    } else {
      return nak(kNakUndefined);
    }
  } catch (const core::InputError&) {
    return nak(kNakUndefined);  // the deck refused (e.g. a cue-up to a label it lacks)
  }
  return ack;
}

}  // namespace dome::capture
