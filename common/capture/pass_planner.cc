#include "capture/pass_planner.h"

#include <chrono>
#include <sstream>
#include <thread>

#include "core/error.h"

namespace dome::capture {

void CaptureOptions::Check() const {
  core::Require(
      IsValidLabel(range.first, layout.standard) && IsValidLabel(range.last, layout.standard) &&
          FrameNumber(range.first, layout.standard) <= FrameNumber(range.last, layout.standard),
      "range",
      "expected FIRST-LAST, valid labels on " + StandardName(layout.standard) +
          ", first not after last");
  core::Require(every >= 1, "every", "must be >= 1 (frames)");
  core::Require(preroll_frames >= 0, "preroll_frames", "must be >= 0 (frames)");
  core::Require(overrun_frames >= 1, "overrun_frames", "must be >= 1 (frames)");
  core::Require(max_passes >= 1, "max_passes", "must be >= 1");
  core::Require(max_idle_passes >= 1, "max_idle_passes", "must be >= 1");
  core::Require(max_deck_errors >= 1, "max_deck_errors", "must be >= 1");
  core::Require(cue_timeout_ms > 0, "cue_timeout_ms", "must be > 0 (milliseconds)");
}

std::string CaptureSummary::BriefReport() const {
  std::ostringstream out;
  out << "captured " << captured << " of " << wanted << " frames in " << passes.size() << " passes";
  for (const auto& p : passes) {
    out << "\n  pass " << p.pass << " (cued to " << p.cued_to.Text() << "): " << p.new_frames
        << " new, " << p.repeats << " repeats, " << p.refused << " not kept by the digitizer, "
        << p.unreadable << " without VITC, " << p.out_of_order << " out of order, " << p.frames_seen
        << " frames seen";
    if (!p.deck_error.empty()) out << "; deck error: " << p.deck_error;
  }
  if (!missing.empty()) {
    out << "\n  missing " << missing.size() << ":";
    for (size_t i = 0; i < missing.size() && i < 20; ++i) out << " " << missing[i].Text();
    if (missing.size() > 20) out << " ...";
  }
  return out.str();
}

PassPlanner::PassPlanner(Deck* deck, Digitizer* digitizer, const CaptureOptions& options)
    : deck_(deck), digitizer_(digitizer), options_(options) {
  options_.Check();
  const int64_t first = FrameNumber(options_.range.first, options_.layout.standard);
  const int64_t last = FrameNumber(options_.range.last, options_.layout.standard);
  for (int64_t n = first; n <= last; n += options_.every) wanted_.push_back(n);
  wanted_set_.insert(wanted_.begin(), wanted_.end());
}

void PassPlanner::MarkCaptured(const take::Timecode& tc) {
  if (!IsValidLabel(tc, options_.layout.standard)) return;
  const int64_t n = FrameNumber(tc, options_.layout.standard);
  if (wanted_set_.count(n)) captured_.insert(n);
}

CaptureSummary PassPlanner::Run(const FrameSink& sink, const ProgressFn& progress) {
  CaptureSummary summary;
  summary.wanted = static_cast<int>(wanted_.size());
  int idle = 0, deck_errors = 0;
  for (int pass = 1; pass <= options_.max_passes && captured_.size() < wanted_.size(); ++pass) {
    PassReport report = RunPass(pass, sink, progress);
    summary.passes.push_back(report);
    if (progress) progress(report, static_cast<int>(captured_.size()), summary.wanted, true);
    if (!report.deck_error.empty()) {
      if (++deck_errors >= options_.max_deck_errors) {
        throw core::InputError(deck_->Name(), "gave up after " + std::to_string(deck_errors) +
                                                  " passes in a row failed: " + report.deck_error);
      }
      continue;
    }
    deck_errors = 0;
    idle = report.new_frames == 0 ? idle + 1 : 0;
    if (idle >= options_.max_idle_passes) break;
  }
  summary.captured = static_cast<int>(captured_.size());
  for (int64_t n : wanted_) {
    if (!captured_.count(n)) summary.missing.push_back(LabelOf(n, options_.layout.standard));
  }
  return summary;
}

PassReport PassPlanner::RunPass(int pass, const FrameSink& sink, const ProgressFn& progress) {
  const VideoStandard standard = options_.layout.standard;
  PassReport report;
  report.pass = pass;
  int64_t first_missing = wanted_.back();
  for (int64_t n : wanted_) {
    if (!captured_.count(n)) {
      first_missing = n;
      break;
    }
  }
  const int64_t cue = std::max<int64_t>(0, first_missing - options_.preroll_frames);
  report.cued_to = LabelOf(cue, standard);
  const int64_t last_wanted = wanted_.back();
  // A pass never reads more than the stretch it covers plus generous slack, whatever
  // the tape carries (e.g. long stretches without VITC).
  const int64_t max_frames = (last_wanted - cue) + options_.overrun_frames + 600;

  try {
    deck_->CueUpWithData(report.cued_to);
    const auto deadline =
        std::chrono::steady_clock::now() + std::chrono::milliseconds(options_.cue_timeout_ms);
    while (!deck_->Status().cue_complete) {
      core::Require(std::chrono::steady_clock::now() < deadline, deck_->Name(),
                    "cue-up to " + report.cued_to.Text() + " did not complete within " +
                        std::to_string(options_.cue_timeout_ms) + " ms");
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    deck_->Play();
  } catch (const core::InputError& e) {
    report.deck_error = e.what();
    return report;
  }

  const VitcDecoder decoder(options_.layout.DecoderOptions());
  int64_t previous = -1;
  int past_end = 0;
  cv::Mat frame, stored;
  while (report.frames_seen < max_frames && digitizer_->Next(&frame)) {
    ++report.frames_seen;
    const auto vitc = decoder.ReadFirst(frame);
    if (!vitc || !IsValidLabel(vitc->word.time, standard)) {
      ++report.unreadable;
      continue;
    }
    const int64_t n = FrameNumber(vitc->word.time, standard);
    if (n <= previous) ++report.out_of_order;
    previous = n;
    if (n > last_wanted) {
      if (++past_end >= options_.overrun_frames) break;
      continue;
    }
    if (!wanted_set_.count(n)) continue;
    if (captured_.count(n)) {
      ++report.repeats;
      continue;
    }
    if (!digitizer_->Keep(&stored)) {
      ++report.refused;
      continue;
    }
    CapturedFrame captured;
    captured.time = vitc->word.time;
    captured.vitc_row = vitc->row;
    captured.pass = pass;
    captured.take_image = TakeImage(stored, options_.layout, options_.fields,
                                    digitizer_->Name() + " frame " + vitc->word.time.Text());
    sink(captured);
    captured_.insert(n);
    ++report.new_frames;
    if (progress)
      progress(report, static_cast<int>(captured_.size()), static_cast<int>(wanted_.size()), false);
  }
  try {
    deck_->Stop();
  } catch (const core::InputError& e) {
    report.deck_error = e.what();
  }
  return report;
}

}  // namespace dome::capture
