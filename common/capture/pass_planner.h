// Rewind-play passes over a tape until every wanted frame is captured (seed §2.1).
//
// Each pass cues the deck `preroll_frames` before the first frame still missing, plays,
// reads every frame's VITC as it goes by, asks the digitizer to keep each frame whose
// time code is wanted and not yet captured, and stops the deck once the signal is
// `overrun_frames` past the end of the range. Passes repeat until the range is
// complete, `max_passes` is reached, or passes stop bringing new frames. Frames whose
// VITC cannot be read, repeats and frames out of order are counted and skipped; a deck
// that fails a command ends that pass, and `max_deck_errors` failures in a row end the
// capture with the deck's error.
#pragma once

#include <functional>
#include <set>
#include <string>
#include <vector>

#include "capture/deck.h"
#include "capture/digitizer.h"
#include "capture/fields.h"
#include "capture/tape.h"
#include "capture/timecode_count.h"

namespace dome::capture {

struct CaptureOptions {
  TimecodeRange range;         // wanted frames, first and last included
  int every = 1;               // keep every n-th frame of the range from its first (seed: 5, 6 Hz)
  int preroll_frames = 30;     // cue this many frames before the first missing one, frames
  int overrun_frames = 3;      // frames read past the range's end before stopping, frames
  int max_passes = 12;         // passes before giving up
  int max_idle_passes = 2;     // passes in a row that bring nothing new before giving up
  int max_deck_errors = 3;     // deck failures in a row before giving up
  int cue_timeout_ms = 10000;  // wait for a cue-up to complete, milliseconds
  TapeLayout layout;           // where VITC and the picture are on the digitized frame
  FieldOptions fields;         // which field to keep

  // Throws core::InputError naming the option out of range.
  void Check() const;
};

// One frame captured: its time code, where its VITC was read, and the take image.
struct CapturedFrame {
  take::Timecode time;
  int vitc_row = 0;
  int pass = 0;        // 1-based
  cv::Mat take_image;  // 8-bit grey, first field, column pairs averaged (capture/fields.h)
};

struct PassReport {
  int pass = 0;  // 1-based
  take::Timecode cued_to;
  int frames_seen = 0;     // frames of signal read
  int new_frames = 0;      // the yield: wanted frames captured for the first time
  int repeats = 0;         // wanted frames already captured
  int refused = 0;         // wanted new frames the digitizer could not keep
  int unreadable = 0;      // frames without a valid VITC word
  int out_of_order = 0;    // frames whose time code went backwards
  std::string deck_error;  // why the pass ended early, if the deck failed
};

struct CaptureSummary {
  int wanted = 0;
  int captured = 0;
  std::vector<PassReport> passes;
  std::vector<take::Timecode> missing;  // wanted frames not captured
  bool complete() const { return captured == wanted; }
  std::string BriefReport() const;
};

using FrameSink = std::function<void(const CapturedFrame&)>;
// Called after each new frame (pass_done false) and at the end of each pass (true).
using ProgressFn =
    std::function<void(const PassReport& pass, int captured, int wanted, bool pass_done)>;

class PassPlanner {
 public:
  // Throws core::InputError when the options are out of range.
  PassPlanner(Deck* deck, Digitizer* digitizer, const CaptureOptions& options);

  // Frames already captured (e.g. found in a spool), not captured again.
  void MarkCaptured(const take::Timecode& tc);
  // Runs passes; `sink` gets each new frame once. Throws core::InputError naming the
  // deck after max_deck_errors failures in a row.
  CaptureSummary Run(const FrameSink& sink, const ProgressFn& progress = {});

  // The wanted frames, as frame numbers, in order.
  const std::vector<int64_t>& wanted() const { return wanted_; }

 private:
  PassReport RunPass(int pass, const FrameSink& sink, const ProgressFn& progress);

  Deck* deck_;
  Digitizer* digitizer_;
  CaptureOptions options_;
  std::vector<int64_t> wanted_;
  std::set<int64_t> wanted_set_, captured_;
};

}  // namespace dome::capture
