#include "capture/sim_deck.h"

#include <algorithm>
#include <thread>

#include "core/error.h"

namespace dome::capture {

SimDeck::SimDeck(const std::filesystem::path& tape, const TapeLayout& layout)
    : name_("sim:" + tape.string()), layout_(layout), frames_(ReadTapeFrames(tape)) {
  Index();
}

SimDeck::SimDeck(std::vector<cv::Mat> frames, const TapeLayout& layout, const std::string& name)
    : name_(name), layout_(layout), frames_(std::move(frames)) {
  core::Require(!frames_.empty(), name_, "the tape holds no frames");
  Index();
}

void SimDeck::Index() {
  const VitcDecoder decoder(layout_.DecoderOptions());
  std::vector<int64_t> read(frames_.size(), -1);
  int first_read = -1;
  for (size_t i = 0; i < frames_.size(); ++i) {
    core::Require(frames_[i].type() == CV_8UC1 && frames_[i].rows > layout_.VbiRows(), name_,
                  "frame " + std::to_string(i) + " is not an 8-bit grey tape frame");
    const auto vitc = decoder.ReadFirst(frames_[i]);
    if (vitc && IsValidLabel(vitc->word.time, layout_.standard)) {
      read[i] = FrameNumber(vitc->word.time, layout_.standard);
      if (first_read < 0) first_read = static_cast<int>(i);
    }
  }
  core::Require(first_read >= 0, name_, "no frame of the tape carries readable VITC");
  timecodes_.assign(frames_.size(), 0);
  for (int i = 0; i < static_cast<int>(frames_.size()); ++i) {
    if (read[i] >= 0) {
      timecodes_[i] = read[i];
    } else if (i < first_read) {
      timecodes_[i] = std::max<int64_t>(0, read[first_read] - (first_read - i));
    } else {
      timecodes_[i] = timecodes_[i - 1] + 1;  // counted on by the control track
    }
  }
}

void SimDeck::Play() {
  std::lock_guard lock(mutex_);
  transport_ = position_ < frame_count() ? Transport::kPlaying : Transport::kStopped;
  cue_complete_ = false;
}

void SimDeck::Stop() {
  std::lock_guard lock(mutex_);
  transport_ = Transport::kStopped;
}

void SimDeck::FastForward() {
  std::lock_guard lock(mutex_);
  position_ = frame_count() - 1;
  transport_ = Transport::kStopped;
  cue_complete_ = false;
}

void SimDeck::Rewind() {
  std::lock_guard lock(mutex_);
  position_ = 0;
  transport_ = Transport::kStopped;
  cue_complete_ = false;
}

void SimDeck::CueUpWithData(const take::Timecode& tc) {
  core::Require(IsValidLabel(tc, layout_.standard), name_,
                "cue-up to " + tc.Text() + ": not a label on " + StandardName(layout_.standard));
  const int64_t want = FrameNumber(tc, layout_.standard);
  std::lock_guard lock(mutex_);
  int at = frame_count() - 1;
  for (int i = 0; i < frame_count(); ++i) {
    if (timecodes_[i] >= want) {
      at = i;
      break;
    }
  }
  position_ = at;
  transport_ = Transport::kStopped;
  cue_complete_ = true;
  clock_s_ += kCueSeconds;
}

take::Timecode SimDeck::CurrentTime() {
  std::lock_guard lock(mutex_);
  const int at = std::min(position_, frame_count() - 1);
  return LabelOf(timecodes_[at] % FramesPerDay(layout_.standard), layout_.standard);
}

DeckStatus SimDeck::Status() {
  std::lock_guard lock(mutex_);
  DeckStatus status;
  status.transport = transport_;
  status.cue_complete = cue_complete_;
  return status;
}

bool SimDeck::NextFrame(cv::Mat* frame, double* time_s) {
  std::chrono::steady_clock::time_point due;
  {
    std::lock_guard lock(mutex_);
    if (transport_ != Transport::kPlaying) return false;
    if (position_ >= frame_count()) {
      transport_ = Transport::kStopped;
      position_ = frame_count() - 1;
      return false;
    }
    *frame = frames_[position_];
    *time_s = clock_s_;
    clock_s_ += 1.0 / FramesPerSecond(layout_.standard);
    ++position_;
    if (pace_ > 0) {
      due = pace_origin_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                               std::chrono::duration<double>(*time_s / pace_));
    }
  }
  // Outside the lock, so a deck emulator can still answer while the frame "plays".
  if (pace_ > 0) std::this_thread::sleep_until(due);
  return true;
}

void SimDeck::SetPace(double signal_seconds_per_second) {
  core::Require(signal_seconds_per_second >= 0, "pace",
                "must not be negative, got " + std::to_string(signal_seconds_per_second));
  std::lock_guard lock(mutex_);
  pace_ = signal_seconds_per_second;
  pace_origin_ = std::chrono::steady_clock::now() -
                 std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                     std::chrono::duration<double>(pace_ > 0 ? clock_s_ / pace_ : 0.0));
}

}  // namespace dome::capture
