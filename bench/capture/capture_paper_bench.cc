// Captures every camera's tape of a synthetic take with simulated decks and
// digitizers, all publishing into one frame ingest, and checks the result against the
// take's own images: every wanted frame stored once, under its time code, pixel for
// pixel the rendered first field. Prints passes and per-pass yields.
//
//   capture_paper_bench --take TAKE [--generate] [--keep-per-second 10]
//                       [--drop-probability 0.02] [--seed 1]
#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <map>
#include <thread>

#include "capture/agent.h"
#include "capture/publish.h"
#include "core/error.h"
#include "core/timer.h"
#include "io/image_io.h"
#include "synth/synth.h"

namespace fs = std::filesystem;
using namespace dome;

int main(int argc, char** argv) {
  CLI::App app{"capture a synthetic take's tapes with simulated agents"};
  fs::path take, work = fs::temp_directory_path() / "dome_capture_paper_bench";
  bool generate = false;
  capture::AgentOptions base;
  base.every = 5;
  base.preroll_frames = 5;
  app.add_option("--take", take, "synthetic take with tape/<camera>.avi")->required();
  app.add_flag("--generate", generate, "generate the paper preset into --take first");
  app.add_option("--work", work, "folder for the ingest's take and the spools (emptied first)");
  app.add_option("--keep-per-second", base.keep_per_second,
                 "digitizer bandwidth, frames/s (0 = all)");
  app.add_option("--drop-probability", base.drop_probability, "digitizer random drops");
  app.add_option("--seed", base.seed, "seed of the drops");
  CLI11_PARSE(app, argc, argv);
  try {
    if (generate) {
      synth::SynthOptions options;
      options.overwrite = true;
      options.write_calibration = false;
      options.write_tape_video = true;
      std::printf("%s\n", synth::GenerateTake(options, take).BriefReport().c_str());
    }
    fs::remove_all(work);
    std::vector<std::string> cameras, instants;
    for (const auto& e : fs::directory_iterator(take / "tape")) {
      if (e.path().extension() == ".avi") cameras.push_back(e.path().stem().string());
      if (e.is_directory()) instants.push_back(e.path().filename().string());
    }
    std::sort(cameras.begin(), cameras.end());
    std::sort(instants.begin(), instants.end());
    if (cameras.empty() || instants.empty())
      throw core::InputError(take.string(), "no tape/<camera>.avi");

    capture::FrameIngest ingest({.bind = "tcp://127.0.0.1:*", .take_dir = work / "take"});
    const std::string endpoint = ingest.endpoint();
    std::atomic<bool> stop{false};
    std::thread server([&] {
      while (!stop) ingest.Poll(20);
    });

    const core::Stopwatch clock;
    std::vector<capture::AgentResult> results(cameras.size());
    std::atomic<size_t> next{0};
    std::vector<std::thread> agents;
    for (int t = 0; t < 2; ++t) {
      agents.emplace_back([&] {
        for (size_t i = next++; i < cameras.size(); i = next++) {
          capture::AgentOptions options = base;
          options.camera_id = cameras[i];
          options.deck = "sim:" + (take / "tape" / (cameras[i] + ".avi")).string();
          options.digitizer = "sim";
          options.range = instants.front().substr(0, 2) + ":" + instants.front().substr(3, 2) +
                          ":" + instants.front().substr(6, 2) + ":" +
                          instants.front().substr(9, 2) + "-" + instants.back().substr(0, 2) + ":" +
                          instants.back().substr(3, 2) + ":" + instants.back().substr(6, 2) + ":" +
                          instants.back().substr(9, 2);
          options.master = endpoint;
          options.spool_dir = work / "spool";
          options.seed = base.seed + i;
          results[i] = capture::RunCaptureAgent(options, nullptr);
        }
      });
    }
    for (auto& a : agents) a.join();
    const double seconds = clock.ElapsedSeconds();
    stop = true;
    server.join();

    // Passes and per-pass yields over all agents.
    std::map<int, std::pair<int, int>> per_pass;  // pass -> (agents that ran it, new frames)
    std::map<size_t, int> pass_counts;
    int wanted = 0, captured = 0, delivered = 0;
    for (const auto& r : results) {
      wanted += r.summary.wanted;
      captured += r.summary.captured;
      delivered += r.delivered;
      ++pass_counts[r.summary.passes.size()];
      for (const auto& p : r.summary.passes) {
        ++per_pass[p.pass].first;
        per_pass[p.pass].second += p.new_frames;
      }
    }
    // Every wanted frame in the ingest's take, identical to the rendered take image.
    int stored = 0, identical = 0;
    for (const auto& cam : cameras) {
      for (const auto& instant : instants) {
        const fs::path got = work / "take" / "frames" / instant / (cam + ".png");
        if (!fs::exists(got)) continue;
        ++stored;
        const cv::Mat a = io::ReadImage(got, io::ImageMode::kGray8);
        const cv::Mat b =
            io::ReadImage(take / "frames" / instant / (cam + ".png"), io::ImageMode::kGray8);
        identical += a.size() == b.size() && cv::countNonZero(a != b) == 0;
      }
    }
    std::printf(
        "agents: %zu cameras x %zu instants; digitizer keeps %g frames/s (0 = all), drops %g\n",
        cameras.size(), instants.size(), base.keep_per_second, base.drop_probability);
    std::printf(
        "captured %d of %d wanted; delivered by %d of %zu agents; ingest stored %lld, duplicates "
        "%lld, "
        "rejected %lld\n",
        captured, wanted, delivered, cameras.size(), static_cast<long long>(ingest.stored()),
        static_cast<long long>(ingest.duplicates()), static_cast<long long>(ingest.rejected()));
    std::printf(
        "in the take: %d frames, %d identical pixel for pixel to the rendered take images\n",
        stored, identical);
    for (const auto& [n, count] : pass_counts)
      std::printf("agents that needed %zu passes: %d\n", n, count);
    for (const auto& [pass, v] : per_pass) {
      std::printf("pass %d: run by %d agents, %d new frames (%.1f%% of wanted)\n", pass, v.first,
                  v.second, 100.0 * v.second / wanted);
    }
    std::printf("wall time %.1f s\n", seconds);
    const bool ok = captured == wanted && stored == wanted && identical == wanted &&
                    ingest.stored() == wanted && delivered == static_cast<int>(cameras.size());
    std::printf("%s\n", ok ? "OK" : "FAILED");
    return ok ? 0 : 1;
  } catch (const core::InputError& e) {
    std::fprintf(stderr, "capture_paper_bench: %s\n", e.what());
    return 2;
  }
}
