// A simulated deck playing a tape file (capture/tape.h) as fast as it is read.
//
// The tape's position is a frame index. The deck knows each frame's time code as a
// real deck's control track does: from the frame's VITC, and across frames whose
// VITC cannot be read, counted on from the last frame it could read. Cue-up stops on
// the first frame whose time code is at or after the wanted one; play then puts out
// one frame per call of NextFrame, the signal clock advancing one frame period each
// (1/29.97 s or 1/25 s), until Stop or the end of the tape. A cue-up takes
// kCueSeconds of signal time with nothing played (a deck winds and pre-rolls); fast-
// forward and rewind wind to the tape's end or start at once and stop there. With a
// pace set, NextFrame waits so that the signal clock keeps to wall time (times the
// pace), as a real deck's playback does.
//
// Thread-safe: a deck emulator may drive it while a digitizer reads its signal.
#pragma once

#include <chrono>
#include <filesystem>
#include <mutex>
#include <vector>

#include "capture/deck.h"
#include "capture/tape.h"

namespace dome::capture {

class SimDeck : public Deck, public VideoSignal {
 public:
  static constexpr double kCueSeconds = 2.0;  // signal time a cue-up takes, seconds

  // Reads the whole tape. Throws core::InputError naming the file when it cannot be
  // read or carries no readable VITC at all.
  SimDeck(const std::filesystem::path& tape, const TapeLayout& layout);
  // A tape given as frames (tests); `name` names it in errors.
  SimDeck(std::vector<cv::Mat> frames, const TapeLayout& layout, const std::string& name);

  std::string Name() const override { return name_; }
  void Play() override;
  void Stop() override;
  void FastForward() override;
  void Rewind() override;
  void CueUpWithData(const take::Timecode& tc) override;
  take::Timecode CurrentTime() override;
  DeckStatus Status() override;

  bool NextFrame(cv::Mat* frame, double* time_s) override;

  // Signal seconds per wall second from now on (1 = real time); 0 = as fast as read.
  void SetPace(double signal_seconds_per_second);

  int frame_count() const { return static_cast<int>(frames_.size()); }
  const TapeLayout& layout() const { return layout_; }
  // The control-track time code of frame `index` as a frame number.
  int64_t FrameTimecode(int index) const { return timecodes_[index]; }

 private:
  void Index();

  std::string name_;
  TapeLayout layout_;
  std::vector<cv::Mat> frames_;
  std::vector<int64_t> timecodes_;  // per frame, frame numbers on layout_.standard

  mutable std::mutex mutex_;
  int position_ = 0;
  Transport transport_ = Transport::kStopped;
  bool cue_complete_ = false;
  double clock_s_ = 0.0;  // the signal clock, seconds
  double pace_ = 0.0;     // signal seconds per wall second; 0 = unpaced
  std::chrono::steady_clock::time_point pace_origin_;  // wall time of signal clock 0
};

}  // namespace dome::capture
