#include "capture-agent/agent.h"

#include <algorithm>
#include <chrono>

#include "capture/sim_deck.h"
#include "capture/sony9pin.h"
#include "core/error.h"
#include "ingest/publish.h"

namespace dome::capture_agent {
using namespace capture;

namespace {
bool StartsWith(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }
}  // namespace

void AgentOptions::Check() const {
  core::Require(!camera_id.empty(), "camera_id", "required: the camera id this tape recorded");
  core::Require(StartsWith(deck, "sim:") || StartsWith(deck, "serial:"), "deck",
                "got '" + deck + "'; expected serial:/dev/ttyXX or sim:TAPE");
  core::Require(!digitizer.empty(), "digitizer", "expected v4l2:/dev/videoN, file:PATH or sim");
  core::Require(digitizer != "sim" || StartsWith(deck, "sim:"), "digitizer",
                "sim digitizes a simulated deck's signal; use it with deck sim:TAPE");
  ParseRange(range, ParseStandard(standard, "standard"), "range");
  core::Require(!master.empty(), "master", "required: the frame ingest's address");
  core::Require(every >= 1, "every", "must be at least 1, got " + std::to_string(every));
  core::Require(preroll_frames >= 0, "preroll_frames", "must not be negative");
  core::Require(max_passes >= 1, "max_passes", "must be at least 1");
  core::Require(keep_per_second >= 0, "keep_per_second", "must not be negative");
  core::Require(drop_probability >= 0 && drop_probability <= 1, "drop_probability",
                "must be in [0, 1]");
  core::Require(sim_pace >= 0, "sim_pace", "must not be negative");
  core::Require(ack_timeout_ms > 0, "ack_timeout_ms", "must be positive");
  core::Require(flush_timeout_ms >= 0, "flush_timeout_ms", "must not be negative");
  core::Require(progress_interval_ms >= 0, "progress_interval_ms", "must not be negative");
  socket.Check();
}

AgentResult RunCaptureAgent(const AgentOptions& options, std::FILE* progress) {
  options.Check();
  TapeLayout layout;
  layout.standard = ParseStandard(options.standard, "standard");

  CaptureOptions capture;
  capture.range = ParseRange(options.range, layout.standard, "range");
  capture.every = options.every;
  capture.preroll_frames = options.preroll_frames;
  capture.max_passes = options.max_passes;
  capture.layout = layout;
  capture.fields.upper_field_first = !options.lower_field_first;
  capture.Check();

  // The deck, and the signal a simulated digitizer watches.
  std::unique_ptr<Deck> deck;
  VideoSignal* signal = nullptr;
  if (StartsWith(options.deck, "sim:")) {
    auto sim = std::make_unique<SimDeck>(options.deck.substr(4), layout);
    sim->SetPace(options.sim_pace);
    signal = sim.get();
    deck = std::move(sim);
  } else {
    Sony9PinOptions serial;
    serial.drop_frame = layout.standard == VideoStandard::k525DropFrame;
    deck = std::make_unique<Sony9PinDeck>(options.deck.substr(7), serial);
  }
  std::unique_ptr<Digitizer> digitizer;
  if (options.digitizer == "sim") {
    SimDigitizerOptions sim;
    sim.keep_per_second = options.keep_per_second;
    sim.drop_probability = options.drop_probability;
    sim.seed = options.seed;
    digitizer = std::make_unique<SimDigitizer>(signal, sim);
  } else {
    digitizer = std::make_unique<OpenCvDigitizer>(options.digitizer);
  }

  ingest::PublisherOptions publish;
  publish.endpoint = options.master;
  publish.spool_dir = options.spool_dir;
  publish.ack_timeout_ms = options.ack_timeout_ms;
  publish.socket = options.socket;
  ingest::FramePublisher publisher(options.camera_id, publish);

  PassPlanner planner(deck.get(), digitizer.get(), capture);
  for (const auto& tc : publisher.spooled_at_start()) planner.MarkCaptured(tc);
  if (progress && !publisher.spooled_at_start().empty()) {
    std::fprintf(progress, "[%s] %zu frames in the spool from an earlier run; sending them first\n",
                 options.camera_id.c_str(), publisher.spooled_at_start().size());
  }

  ingest::AgentProgress last;
  auto last_sent = std::chrono::steady_clock::time_point{};
  const auto on_progress = [&](const PassReport& pass, int captured, int wanted, bool pass_done) {
    publisher.Pump(0);
    const auto now = std::chrono::steady_clock::now();
    const bool due = now - last_sent >= std::chrono::milliseconds(options.progress_interval_ms);
    const bool new_pass = pass.pass != last.pass;
    last.pass = pass.pass;
    last.captured = captured;
    last.wanted = wanted;
    last.pass_yield = pass.new_frames;
    last.error = pass.deck_error;
    if (new_pass || pass_done || due) {
      publisher.SendProgress(last);
      last_sent = now;
    }
    if (!progress) return;
    if (pass_done) {
      std::fprintf(progress,
                   "[%s] pass %d (cued to %s): %d new, %d repeats, %d not kept, %d without VITC; "
                   "%d/%d frames captured, %zu awaiting acknowledgement\n",
                   options.camera_id.c_str(), pass.pass, pass.cued_to.Text().c_str(),
                   pass.new_frames, pass.repeats, pass.refused, pass.unreadable, captured, wanted,
                   publisher.pending());
      if (!pass.deck_error.empty()) {
        std::fprintf(progress, "[%s]   deck error: %s\n", options.camera_id.c_str(),
                     pass.deck_error.c_str());
      }
    }
    std::fflush(progress);
  };
  AgentResult result;
  try {
    result.summary =
        planner.Run([&](const CapturedFrame& frame) { publisher.Publish(frame); }, on_progress);
  } catch (const std::exception& e) {
    // The ingest shows why this camera stopped; the frames already captured still go.
    last.done = true;
    last.error = e.what();
    publisher.SendProgress(last);
    publisher.Flush(std::min(options.flush_timeout_ms, 5000));
    throw;
  }
  last.done = true;
  last.captured = result.summary.captured;
  last.wanted = result.summary.wanted;
  if (!result.summary.complete() && last.error.empty()) {
    last.error = std::to_string(result.summary.missing.size()) + " frames not captured after " +
                 std::to_string(result.summary.passes.size()) + " passes";
  }
  // The frames first, so the final progress carries the final acknowledged count; then
  // that progress, acknowledged in turn (within what is left of the flush time).
  const auto flush_end =
      std::chrono::steady_clock::now() + std::chrono::milliseconds(options.flush_timeout_ms);
  publisher.Flush(options.flush_timeout_ms);
  publisher.SendProgress(last);
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                        flush_end - std::chrono::steady_clock::now())
                        .count();
  publisher.Flush(static_cast<int>(std::max<int64_t>(left, 0)));
  result.delivered = publisher.pending() == 0;
  result.acknowledged = publisher.acknowledged();
  result.resent = publisher.resent();
  result.reconnects = publisher.reconnects();
  return result;
}

}  // namespace dome::capture_agent
