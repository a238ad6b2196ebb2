// A video tape deck under computer control (seed §2.1: "a computer-controllable VCR"),
// behind one interface: a Sony 9-pin RS-422 deck (capture/sony9pin.h) or a simulated
// deck playing a tape file (capture/sim_deck.h).
//
// Every call throws core::InputError naming the deck (Name()) when the deck refuses
// or does not answer; a caller may retry.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "take/timecode.h"

namespace dome::capture {

enum class Transport { kStopped, kPlaying, kFastForward, kRewind };

struct DeckStatus {
  Transport transport = Transport::kStopped;
  bool tape_loaded = true;
  bool cue_complete = false;  // the last cue-up reached its time code and holds there
};

class Deck {
 public:
  virtual ~Deck() = default;
  virtual std::string Name() const = 0;  // "serial:/dev/ttyS0", "sim:TAPE"

  virtual void Play() = 0;
  virtual void Stop() = 0;
  virtual void FastForward() = 0;
  virtual void Rewind() = 0;
  // Winds to the frame labelled `tc` (or the first after it) and holds there stopped;
  // Status().cue_complete tells when it is there.
  virtual void CueUpWithData(const take::Timecode& tc) = 0;
  // The time code under the head (current time sense).
  virtual take::Timecode CurrentTime() = 0;
  virtual DeckStatus Status() = 0;
};

// What a deck puts out on its video connector while it plays: the frames, in order.
// Digitizers read it (capture/digitizer.h).
class VideoSignal {
 public:
  virtual ~VideoSignal() = default;
  // The next frame played (8-bit grey, vertical interval included) and the time it
  // was played, seconds on the signal's clock (monotonic across passes). false when
  // nothing is playing (stopped, end of tape).
  virtual bool NextFrame(cv::Mat* frame, double* time_s) = 0;
};

}  // namespace dome::capture
