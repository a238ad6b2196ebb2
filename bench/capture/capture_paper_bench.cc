// Captures every camera's tape of a synthetic take with simulated decks and
// digitizers, all publishing into one frame ingest, and checks the result against the
// take's own images: every wanted frame stored once, under its time code, pixel for
// pixel the rendered first field. Prints passes and per-pass yields. With --master the
// ingest is a dome-master process (--capture-bind) next to this binary instead of one
// in this process, and its status events give the frames it stored per camera.
//
//   capture_paper_bench --take TAKE [--generate] [--keep-per-second 10]
//                       [--drop-probability 0.02] [--seed 1] [--master]
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <map>
#include <mutex>
#include <optional>
#include <thread>
#include <zmq.hpp>

#include "capture-agent/agent.h"
#include "core/error.h"
#include "core/timer.h"
#include "ingest/publish.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "net/events.h"
#include "runtime.pb.h"
#include "synth/synth.h"

namespace fs = std::filesystem;
using namespace dome;

namespace {

std::string FreeLoopbackEndpoint() {
  zmq::context_t context;
  zmq::socket_t socket(context, zmq::socket_type::router);
  socket.bind("tcp://127.0.0.1:*");
  return socket.get(zmq::sockopt::last_endpoint);
}

// A dome-master hosting the frame ingest, in its own process; its status events'
// capture progress collected on a thread.
class MasterIngest {
 public:
  MasterIngest(const fs::path& take, const fs::path& log) {
    const fs::path binary = fs::read_symlink("/proc/self/exe").parent_path() / "dome-master";
    capture_ = FreeLoopbackEndpoint();
    const std::string events = FreeLoopbackEndpoint();
    std::vector<std::string> args = {
        binary.string(), "--bind",    FreeLoopbackEndpoint(), "--control", FreeLoopbackEndpoint(),
        "--events",      events,      "--capture-bind",       capture_,    "--take",
        take.string(),   "--insecure"};
    pid_ = ::fork();
    if (pid_ == 0) {
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      std::vector<char*> argv;
      for (auto& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(binary.c_str(), argv.data());
      ::_exit(127);
    }
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (std::chrono::steady_clock::now() < end) {
      if (fs::exists(log) &&
          io::ReadFileBytes(log).find("capture " + capture_) != std::string::npos)
        break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    thread_ = std::thread([this, events] {
      net::EventSubscription subscription(&context_, events, net::SocketOptions{});
      while (!stop_) {
        subscription.Drain(20, [this](const runtime::StatusEvent& ev) {
          if (!ev.has_capture()) return;
          std::lock_guard lock(mutex_);
          last_[ev.capture().camera_id()] = ev.capture();
        });
      }
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the subscriber joins
  }
  ~MasterIngest() {
    stop_ = true;
    thread_.join();
    ::kill(pid_, SIGTERM);
    ::waitpid(pid_, nullptr, 0);
  }
  const std::string& capture_endpoint() const { return capture_; }
  // Waits until `cameras` cameras reported their end; the last event of each.
  std::map<std::string, runtime::CaptureStatus> WaitForFinal(size_t cameras) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (std::chrono::steady_clock::now() < end) {
      {
        std::lock_guard lock(mutex_);
        size_t done = 0;
        for (const auto& [c, s] : last_) done += s.state() != "capturing";
        if (done >= cameras) return last_;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    std::lock_guard lock(mutex_);
    return last_;
  }

 private:
  std::string capture_;
  pid_t pid_ = -1;
  zmq::context_t context_;
  std::mutex mutex_;
  std::map<std::string, runtime::CaptureStatus> last_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"capture a synthetic take's tapes with simulated agents"};
  fs::path take, work = fs::temp_directory_path() / "dome_capture_paper_bench";
  bool generate = false, through_master = false;
  capture_agent::AgentOptions base;
  base.every = 5;
  base.preroll_frames = 5;
  app.add_option("--take", take, "synthetic take with tape/<camera>.avi")->required();
  app.add_flag("--generate", generate, "generate the paper preset into --take first");
  app.add_option("--work", work, "folder for the ingest's take and the spools (emptied first)");
  app.add_option("--keep-per-second", base.keep_per_second,
                 "digitizer bandwidth, frames/s (0 = all)");
  app.add_option("--drop-probability", base.drop_probability, "digitizer random drops");
  app.add_option("--seed", base.seed, "seed of the drops");
  app.add_flag("--master", through_master,
               "publish into a dome-master process (--capture-bind) instead of an in-process "
               "ingest");
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

    fs::create_directories(work);
    std::optional<ingest::FrameIngest> ingest;
    std::optional<MasterIngest> master;
    std::string endpoint;
    if (through_master) {
      master.emplace(work / "take", work / "master.log");
      endpoint = master->capture_endpoint();
    } else {
      ingest.emplace(
          ingest::IngestOptions{.bind = "tcp://127.0.0.1:*", .take_dir = work / "take"});
      endpoint = ingest->endpoint();
    }
    std::atomic<bool> stop{false};
    std::thread server([&] {
      while (!stop && ingest) ingest->Poll(20);
    });

    const core::Stopwatch clock;
    std::vector<capture_agent::AgentResult> results(cameras.size());
    std::atomic<size_t> next{0};
    std::vector<std::thread> agents;
    for (int t = 0; t < 2; ++t) {
      agents.emplace_back([&] {
        for (size_t i = next++; i < cameras.size(); i = next++) {
          capture_agent::AgentOptions options = base;
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
          results[i] = capture_agent::RunCaptureAgent(options, nullptr);
        }
      });
    }
    for (auto& a : agents) a.join();
    const double seconds = clock.ElapsedSeconds();
    stop = true;
    server.join();
    // The ingest's counts: its own, or the master's from its status events.
    int64_t ingest_stored = 0, ingest_duplicates = 0, ingest_rejected = 0;
    int complete_events = 0;
    if (ingest) {
      ingest_stored = ingest->stored();
      ingest_duplicates = ingest->duplicates();
      ingest_rejected = ingest->rejected();
    } else {
      for (const auto& [camera, c] : master->WaitForFinal(cameras.size())) {
        ingest_stored += c.stored();
        complete_events += c.state() == "complete" && c.captured() == c.wanted();
      }
    }

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
    if (ingest) {
      std::printf(
          "captured %d of %d wanted; delivered by %d of %zu agents; ingest stored %lld, "
          "duplicates %lld, rejected %lld\n",
          captured, wanted, delivered, cameras.size(), static_cast<long long>(ingest_stored),
          static_cast<long long>(ingest_duplicates), static_cast<long long>(ingest_rejected));
    } else {
      std::printf(
          "captured %d of %d wanted; delivered by %d of %zu agents; dome-master stored %lld "
          "(its status events); %d of %zu cameras reported complete in them\n",
          captured, wanted, delivered, cameras.size(), static_cast<long long>(ingest_stored),
          complete_events, cameras.size());
    }
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
                    ingest_stored == wanted && delivered == static_cast<int>(cameras.size()) &&
                    (ingest || complete_events == static_cast<int>(cameras.size()));
    std::printf("%s\n", ok ? "OK" : "FAILED");
    return ok ? 0 : 1;
  } catch (const core::InputError& e) {
    std::fprintf(stderr, "capture_paper_bench: %s\n", e.what());
    return 2;
  }
}
