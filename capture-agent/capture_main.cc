// dome-capture: drives one VCR + digitizer through rewind-play passes and publishes the
// VITC-tagged frames (capture-agent/agent.h) to a dome-master (--capture-bind) or the
// stand-alone frame ingest; also that ingest and a Sony 9-pin deck emulator on a
// pseudo-terminal. Like every dome client it talks CURVE (--master-key, --key) unless
// --insecure; the stand-alone ingest is plaintext.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdio>

#include "capture-agent/agent.h"
#include "capture/sim_deck.h"
#include "capture/sony9pin.h"
#include "core/error.h"
#include "ingest/publish.h"
#include "net/security.h"

namespace {

volatile std::sig_atomic_t g_stop = 0;
void OnSignal(int) { g_stop = 1; }

}  // namespace

int main(int argc, char** argv) {
  using namespace dome::capture;
  using dome::capture_agent::AgentOptions;
  using dome::ingest::FrameIngest;
  using dome::ingest::IngestOptions;
  CLI::App app{"dome-capture: digitizes VITC-tagged frames from a tape and publishes them"};
  AgentOptions agent;
  app.add_option("--camera", agent.camera_id, "camera id recorded on this tape");
  app.add_option("--deck", agent.deck, "serial:/dev/ttyS0 (Sony 9-pin) or sim:TAPE (a tape file)");
  app.add_option("--digitizer", agent.digitizer,
                 "v4l2:/dev/video0, file:PATH, or sim (the sim deck's signal)");
  app.add_option("--range", agent.range,
                 "time codes to capture, FIRST-LAST, e.g. 00:00:10:00-00:00:11:20");
  app.add_option("--master", agent.master,
                 "the frame ingest: dome-master --capture-bind, or dome-capture ingest");
  std::string master_key, key;
  bool insecure = false;
  app.add_option("--master-key", master_key, "the master's public key file (CURVE)")
      ->envname("DOME_MASTER_KEY");
  app.add_option("--key", key, "this agent's secret key file, its .pub allowed by the master")
      ->envname("DOME_KEY");
  app.add_flag("--insecure", insecure,
               "plaintext, for a master started with --insecure or dome-capture ingest");
  app.add_option("--spool", agent.spool_dir, "folder keeping frames until acknowledged");
  app.add_option("--standard", agent.standard, "525-ndf, 525-df or 625");
  app.add_option("--every", agent.every, "keep every n-th frame of the range (the seed: 5)");
  app.add_option("--preroll", agent.preroll_frames,
                 "cue this many frames before the first missing one");
  app.add_option("--max-passes", agent.max_passes, "passes before giving up");
  app.add_flag("--lower-field-first", agent.lower_field_first,
               "the odd rows are the first field in time");
  app.add_option("--keep-per-second", agent.keep_per_second,
                 "sim digitizer: frames stored per second (0 = all)");
  app.add_option("--drop-probability", agent.drop_probability,
                 "sim digitizer: chance a stored frame is lost");
  app.add_option("--seed", agent.seed, "sim digitizer: seed of the drops");
  app.add_option("--sim-pace", agent.sim_pace,
                 "sim deck: play at this many times real time (0 = as fast as read)");
  app.add_option("--ack-timeout-ms", agent.ack_timeout_ms,
                 "resend a frame not acknowledged within this");
  app.add_option("--flush-timeout-ms", agent.flush_timeout_ms,
                 "wait at the end for the last acknowledgements");

  IngestOptions ingest;
  CLI::App* ingest_cmd = app.add_subcommand(
      "ingest", "receive frames and store them into a take (stand-alone master side)");
  ingest_cmd->add_option("--bind", ingest.bind, "address to bind, e.g. tcp://*:5570")->required();
  ingest_cmd
      ->add_option("--take", ingest.take_dir,
                   "take folder; frames go to TAKE/frames/<instant>/<camera>.png")
      ->required();

  std::string tape, standard = "525-ndf";
  DeckEmulatorOptions emulate;
  CLI::App* emulate_cmd = app.add_subcommand(
      "emulate-deck", "a Sony 9-pin deck playing a tape file, on a pseudo-terminal");
  emulate_cmd->add_option("--tape", tape, "tape file (FFV1 video with VITC)")->required();
  emulate_cmd->add_option("--standard", standard, "525-ndf, 525-df or 625");
  emulate_cmd->add_option("--nak-first", emulate.nak_first, "answer the first n commands with NAK");
  emulate_cmd->add_option("--silent-after", emulate.silent_after,
                          "stop answering after n commands");
  std::filesystem::path tapes_take;
  int threads = 0;
  CLI::App* tapes_cmd = app.add_subcommand("make-tapes",
                                           "write TAKE/tape/<camera>.avi (FFV1 with VITC) from a "
                                           "synthetic take's tape/<instant>/ frames");
  tapes_cmd->add_option("--take", tapes_take, "the take folder")->required();
  tapes_cmd->add_option("--threads", threads, "worker threads (0 = all)");
  CLI11_PARSE(app, argc, argv);

  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  try {
    if (*ingest_cmd) {
      FrameIngest server(ingest);
      std::printf("ingest: listening on %s, storing into %s\n", server.endpoint().c_str(),
                  ingest.take_dir.c_str());
      std::fflush(stdout);
      while (!g_stop) server.Poll(100);
      std::printf("ingest: %lld stored, %lld duplicates, %lld rejected\n",
                  static_cast<long long>(server.stored()),
                  static_cast<long long>(server.duplicates()),
                  static_cast<long long>(server.rejected()));
      return 0;
    }
    if (*tapes_cmd) {
      const int written = WriteTakeTapes(tapes_take, TapeLayout{}, threads);
      std::printf("make-tapes: %d tapes written to %s\n", written, (tapes_take / "tape").c_str());
      return 0;
    }
    if (*emulate_cmd) {
      TapeLayout layout;
      layout.standard = ParseStandard(standard, "--standard");
      SimDeck deck(tape, layout);
      DeckEmulator emulator(&deck, emulate);
      emulator.Start();
      std::printf("emulate-deck: %s on %s\n", deck.Name().c_str(), emulator.device_path().c_str());
      std::fflush(stdout);
      while (!g_stop) ::usleep(100000);
      return 0;
    }
    // A secure master admits only CURVE clients on its allow-list (net/security.h).
    dome::net::ApplyClientKeys(master_key, key, insecure, &agent.socket);
    const auto result = dome::capture_agent::RunCaptureAgent(agent, stderr);
    std::printf("%s\n", result.summary.BriefReport().c_str());
    std::printf("delivered: %lld acknowledged by %s%s (%lld resent, %d reconnects)\n",
                static_cast<long long>(result.acknowledged), agent.master.c_str(),
                result.delivered ? "" : "; some frames are still in the spool",
                static_cast<long long>(result.resent), result.reconnects);
    return result.summary.complete() && result.delivered ? 0 : 1;
  } catch (const dome::core::InputError& e) {
    std::fprintf(stderr, "dome-capture: %s\n", e.what());
    return 2;
  }
}
