// Deck control by the Sony 9-pin protocol (RS-422, 38.4 kbit/s, 1 start bit, 8 data
// bits, odd parity, 1 stop bit), and an emulated deck that speaks it.
//
// A block is CMD-1 (high nibble: function group; low nibble: number of data bytes,
// 0..15), CMD-2, the data bytes, and a checksum (the low 8 bits of the sum of all
// bytes before it). The controller sends one block and waits for the reply before the
// next. Blocks used here:
//   20 00 STOP            20 01 PLAY           20 10 FAST FWD      20 20 REWIND
//   24 31 CUE UP WITH DATA  data: frames, seconds, minutes, hours (BCD; bit 6 of
//                           the frames byte = drop-frame)
//   61 0C CURRENT TIME SENSE  data: 0x02 = VITC  -> reply 74 06 + time (as above)
//   61 20 STATUS SENSE        data: 0x04 = 4 bytes from byte 0 -> reply 74 20 + bytes
// Replies: 10 01 ACK; 11 12 NAK + one error byte (0x01 undefined command, 0x04
// checksum error, 0x10 parity error, 0x20 buffer overrun, 0x40 framing error, 0x80
// time-out). Status bytes used: byte 0 bit 5 = no tape; byte 1 bit 0 = play, bit 2 =
// fast forward, bit 3 = rewind, bit 5 = stop; byte 2 bit 0 = cue-up complete.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "capture/deck.h"

namespace dome::capture {

struct Sony9PinBlock {
  uint8_t cmd1 = 0;  // the function group nibble (0x20, 0x61, ...); the count is added
  uint8_t cmd2 = 0;
  std::vector<uint8_t> data;

  std::vector<uint8_t> Encode() const;  // with count and checksum
};

uint8_t Sony9PinChecksum(const uint8_t* bytes, size_t n);
// A time code as the four data bytes; and back (nullopt unless valid BCD).
std::vector<uint8_t> EncodeTimeData(const take::Timecode& tc, bool drop_frame);
std::optional<take::Timecode> DecodeTimeData(const uint8_t* data);
// Names of NAK error bits, for messages: "checksum error, parity error".
std::string NakText(uint8_t error);

// A serial port in raw mode at 38400 baud, 8 data bits, odd parity (termios). Throws
// core::InputError naming the device when it cannot be opened or configured.
class SerialPort {
 public:
  explicit SerialPort(const std::string& device);
  ~SerialPort();
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  void Write(const std::vector<uint8_t>& bytes);
  // Reads up to n bytes, waiting at most timeout_ms for the first; returns what came.
  std::vector<uint8_t> Read(size_t n, int timeout_ms);
  void Flush();  // drops unread input
  const std::string& device() const { return device_; }

 private:
  std::string device_;
  int fd_ = -1;
};

struct Sony9PinOptions {
  int reply_timeout_ms = 100;  // wait for a reply block; the protocol asks decks for 9 ms
  int retries = 3;             // tries per command on a time-out or a recoverable NAK
  int retry_delay_ms = 12;     // the protocol asks for 10 ms after a NAK
  bool drop_frame = false;     // cue-up time codes carry the drop-frame bit

  // Throws core::InputError naming the first option out of range.
  void Check() const;
};

// A deck on a serial port. Errors name "serial:<device>".
class Sony9PinDeck : public Deck {
 public:
  Sony9PinDeck(const std::string& device, const Sony9PinOptions& options = {});

  std::string Name() const override { return "serial:" + port_.device(); }
  void Play() override;
  void Stop() override;
  void FastForward() override;
  void Rewind() override;
  void CueUpWithData(const take::Timecode& tc) override;
  take::Timecode CurrentTime() override;
  DeckStatus Status() override;

  // Sends `block`, returns the reply (ACK, data or NAK are checked by the callers
  // above; here: time-outs and recoverable NAKs are retried, the reply's checksum is
  // verified).
  Sony9PinBlock Transact(const Sony9PinBlock& block, const std::string& what);

 private:
  void Command(uint8_t cmd1, uint8_t cmd2, const std::vector<uint8_t>& data,
               const std::string& what);
  std::optional<Sony9PinBlock> ReadReply(int timeout_ms);

  SerialPort port_;
  Sony9PinOptions options_;
};

struct DeckEmulatorOptions {
  int nak_first = 0;            // answer the first n commands with NAK (checksum error)
  int silent_after = -1;        // stop answering after n commands (< 0: never)
  bool nak_everything = false;  // answer every command with NAK (undefined command)

  // Throws core::InputError naming the first option out of range.
  void Check() const;
};

// A deck at the far end of a serial line: speaks the protocol above over a file
// descriptor (the master side of a pseudo-terminal pair), driving `deck`.
class DeckEmulator {
 public:
  // Opens a pseudo-terminal pair; the controller opens device_path().
  DeckEmulator(Deck* deck, const DeckEmulatorOptions& options = {});
  ~DeckEmulator();  // stops the service thread, closes the pair
  DeckEmulator(const DeckEmulator&) = delete;
  DeckEmulator& operator=(const DeckEmulator&) = delete;

  const std::string& device_path() const { return slave_path_; }
  void Start();  // serves on a thread until the object goes away
  int commands_seen() const { return commands_.load(); }

 private:
  void Serve();
  std::vector<uint8_t> Answer(const std::vector<uint8_t>& block);

  Deck* deck_;
  DeckEmulatorOptions options_;
  int master_fd_ = -1;
  int slave_keep_fd_ = -1;  // held open so the pair outlives controller reconnects
  std::string slave_path_;
  std::atomic<bool> stop_{false};
  std::atomic<int> commands_{0};
  std::thread thread_;
};

}  // namespace dome::capture
