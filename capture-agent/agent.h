// One capture agent (`dome-capture`): a deck, a digitizer, the pass planner
// (capture/) and the frame publisher (ingest/publish.h), put together from their specs
// (seed §2.1: one agent per VCR and digitizer).
#pragma once

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "capture/deck.h"
#include "capture/digitizer.h"
#include "capture/pass_planner.h"
#include "ingest/publish.h"

namespace dome::capture_agent {

struct AgentOptions {
  std::string camera_id;          // the camera this tape recorded
  std::string deck;               // serial:/dev/ttyS0 | sim:TAPE
  std::string digitizer = "sim";  // v4l2:/dev/video0 | file:PATH | sim (the sim deck's signal)
  std::string range;              // TC-TC, first and last included
  std::string master;             // the frame ingest, e.g. tcp://master:5570
  std::filesystem::path spool_dir = "capture-spool";  // frames kept until acknowledged
  std::string standard = "525-ndf";                   // 525-ndf | 525-df | 625
  int every = 1;                                      // keep every n-th frame of the range, frames
  int preroll_frames = 30;  // cue this far before the first missing frame, frames
  int max_passes = 12;
  bool lower_field_first = false;  // the odd rows are the first field in time
  double keep_per_second = 0.0;    // sim digitizer: frames it can store per second; 0 = all
  double drop_probability = 0.0;   // sim digitizer: chance of losing a frame it stores
  uint64_t seed = 1;               // sim digitizer: of the drops
  double sim_pace = 0.0;  // sim deck: signal seconds per wall second (1 = real time); 0 = unpaced
  int ack_timeout_ms = 1000;       // resend frames not acknowledged within this, ms
  int flush_timeout_ms = 60000;    // wait at the end for the last acknowledgements, ms
  int progress_interval_ms = 250;  // least time between progress messages within a pass, ms
  net::SocketOptions socket{};     // the publisher's socket: CURVE keys (net/security.h)

  // Throws core::InputError naming the first option out of range ("deck", "range", ...).
  void Check() const;
};

struct AgentResult {
  capture::CaptureSummary summary;
  bool delivered = false;  // every captured frame acknowledged by the ingest
  int64_t acknowledged = 0;
  int64_t resent = 0;
  int reconnects = 0;
};

// Runs the agent; progress lines go to `progress` (nullptr: none) and progress messages
// to the ingest. Throws core::InputError naming the option, file, device or peer at
// fault; once the publisher is up, the ingest is told of the failure first.
AgentResult RunCaptureAgent(const AgentOptions& options, std::FILE* progress);

}  // namespace dome::capture_agent
