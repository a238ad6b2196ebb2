// A bounded soak of the runtime with faults injected (real processes on loopback):
//
//   soak_bench OUT [--sessions 200] [--seed 1] [--faults kill9-master,garbage]
//
// Makes the small synthetic take (one instant) and its undisturbed result with the
// embedded `dome run`, then starts bin/dome-master (plaintext, --state, fixed ports,
// --job-timeout-s 5) and two bin/dome-workers, and runs --sessions sessions one after
// another, each on its own copy of the take and output folder, with one fault drawn
// per session and injected 0-300 ms after submit:
//   none, kill9-worker (SIGKILL a worker, start another), stop-worker (SIGSTOP a worker
//   for 1.5 s), kill9-master (SIGKILL the master, start it again on the same ports and
//   state folder: the session resumes under its id), change-frame (overwrite a frame of
//   the copy), delete-frame, garbage (2,000 random messages to the worker and control
//   ports), disk-full (the output folder on a 1 MiB tmpfs, when this process may mount
//   one; else counted as skipped).
// Each session is waited for up to 120 s. Prints one JSON line: sessions per fault and
// per end state, sessions left running (must be 0), done sessions whose outputs differ
// from the undisturbed run (must be 0), and the master's RSS (MiB) before and after.
// Exits 1 when a session was left running, a done one differs, or the RSS grew more
// than --rss-check (default 0.10, a fraction; negative: not checked).
//
// The RSS rule: the master's VmRSS is read after every session, of the master process
// then running (a kill9-master fault starts a new one, which loads every session of
// the state folder). A master's first sessions lift it to a plateau (ZeroMQ's pools,
// the first session's libraries and decoders) that later sessions do not raise, so a
// reading counts only once its process has served
// --warmup sessions (default 5); "before" is the median of the first 10 readings that
// count, "after" the median of the last 10. Every reading is in OUT/master_rss.jsonl.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>
#include <zmq.hpp>

#include "cli/client.h"
#include "io/file_util.h"
#include "net/wire.h"
#include "pipeline/session.h"
#include "process_rss.h"

namespace fs = std::filesystem;
using namespace dome;
using Clock = std::chrono::steady_clock;

namespace {

std::string Flag(int argc, char** argv, const std::string& name, const std::string& fallback) {
  for (int i = 1; i + 1 < argc; ++i) {
    if (name == argv[i]) return argv[i + 1];
  }
  return fallback;
}

pid_t Spawn(const std::vector<std::string>& args, const fs::path& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  std::vector<std::string> copy = args;
  std::vector<char*> argv;
  for (auto& a : copy) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int err = posix_spawn(&pid, copy[0].c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (err != 0) throw std::runtime_error("cannot start " + copy[0]);
  return pid;
}

void Stop(pid_t pid, int sig = SIGTERM) {
  ::kill(pid, sig);
  ::waitpid(pid, nullptr, 0);
}

std::string FreeEndpoint(zmq::context_t* context) {
  zmq::socket_t s(*context, zmq::socket_type::router);
  s.bind("tcp://127.0.0.1:*");
  return s.get(zmq::sockopt::last_endpoint);
}

struct Cluster {
  fs::path bin, dir;
  std::string workers, control, events;
  pid_t master = -1;
  int master_sessions = 0;  // sessions the running master process has served
  std::vector<pid_t> worker_pids{};
  int started = 0;

  void StartMaster() {
    master_sessions = 0;
    master =
        Spawn({(bin / "dome-master").string(), "--bind", workers, "--control", control, "--events",
               events, "--insecure", "--heartbeat-ms", "200", "--liveness", "3", "--job-timeout-s",
               "5", "--state", (dir / "state").string(), "--log-level", "warn"},
              dir / "master.log");
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  void StartWorker() {
    worker_pids.push_back(
        Spawn({(bin / "dome-worker").string(), "--master", workers, "--threads", "1",
               "--heartbeat-ms", "200", "--liveness", "3", "--insecure", "--log-level", "warn",
               "--name", "soak" + std::to_string(started++)},
              dir / "workers.log"));
  }
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: soak_bench OUT [--sessions 200] [--seed 1]\n");
    return 2;
  }
  const fs::path out = fs::absolute(argv[1]);
  const int sessions = std::stoi(Flag(argc, argv, "--sessions", "200"));
  std::mt19937 rng(std::stoul(Flag(argc, argv, "--seed", "1")));
  fs::remove_all(out);
  fs::create_directories(out);
  const fs::path bin = fs::canonical(fs::path(argv[0])).parent_path();
  const fs::path take = out / "take", reference = out / "reference";
  const std::string dome = (bin / "dome").string();
  const std::string flags = " --voxel-mm 40 --slab-planes 5";
  if (std::system((dome + " synth --preset small --instants 1 --no-tape --no-calib --out " +
                   take.string() + " >" + (out / "synth.log").string() + " 2>&1")
                      .c_str()) != 0 ||
      std::system((dome + " run " + take.string() + " --out " + reference.string() +
                   " --workers 2 --threads 1" + flags + " >" + (out / "reference.log").string() +
                   " 2>&1")
                      .c_str()) != 0) {
    std::fprintf(stderr, "soak_bench: cannot make the take or its reference run (see %s)\n",
                 out.c_str());
    return 2;
  }
  const auto expected = client::SessionOutputFiles(reference);
  runtime::Session base = pipeline::ReadSessionJson(reference / "session.json");
  base.clear_derived();

  zmq::context_t context;
  Cluster c{bin, out, FreeEndpoint(&context), FreeEndpoint(&context), FreeEndpoint(&context)};
  c.StartMaster();
  c.StartWorker();
  c.StartWorker();
  const fs::path disk = out / "disk";
  fs::create_directories(disk);

  std::vector<std::string> faults = {"none",         "kill9-worker", "stop-worker", "kill9-master",
                                     "change-frame", "delete-frame", "garbage",     "disk-full"};
  if (const std::string only = Flag(argc, argv, "--faults", ""); !only.empty()) {
    faults.clear();  // a comma-separated subset, to soak one kind
    std::istringstream in(only);
    for (std::string f; std::getline(in, f, ',');) faults.push_back(f);
  }
  std::map<std::string, std::map<std::string, int>> ends;  // fault -> state -> count
  int left_running = 0, differing = 0;
  const int warmup = std::stoi(Flag(argc, argv, "--warmup", "5"));
  const double rss_check = std::stod(Flag(argc, argv, "--rss-check", "0.10"));
  std::vector<double> counted_rss;  // readings of masters past their warm-up
  std::ofstream rss_log(out / "master_rss.jsonl");
  const auto soak_start = Clock::now();
  for (int i = 0; i < sessions; ++i) {
    const std::string fault = faults[rng() % faults.size()];
    const fs::path copy = out / "takes" / std::to_string(i);
    fs::create_directories(copy.parent_path());
    fs::copy(take, copy, fs::copy_options::recursive);
    bool mounted = false;
    fs::path session_out = out / "outs" / std::to_string(i);
    if (fault == "disk-full") {
      mounted = ::mount("tmpfs", disk.c_str(), "tmpfs", 0, "size=1m") == 0;
      if (!mounted) {
        ++ends[fault]["skipped (cannot mount)"];
        continue;
      }
      session_out = disk / "out";
    }
    runtime::Session s = base;
    s.set_take(copy.string());
    s.set_out(session_out.string());
    runtime::ControlRequest req;
    *req.mutable_submit()->mutable_session() = s;
    std::string id;
    try {
      id = client::Request(&context, c.control, req, 20000).session_id();
    } catch (const std::exception& e) {
      ++ends[fault]["refused at submit"];
      if (mounted) ::umount2(disk.c_str(), MNT_DETACH);
      continue;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(rng() % 300));
    if (fault == "kill9-worker") {
      Stop(c.worker_pids.front(), SIGKILL);
      c.worker_pids.erase(c.worker_pids.begin());
      c.StartWorker();
    } else if (fault == "stop-worker") {
      ::kill(c.worker_pids.front(), SIGSTOP);
      std::this_thread::sleep_for(std::chrono::milliseconds(1500));
      ::kill(c.worker_pids.front(), SIGCONT);
    } else if (fault == "kill9-master") {
      Stop(c.master, SIGKILL);
      c.StartMaster();
    } else if (fault == "change-frame" || fault == "delete-frame") {
      const fs::path frames = copy / "frames";
      const fs::path instant = fs::directory_iterator(frames)->path();
      const fs::path frame = fs::directory_iterator(instant)->path();
      if (fault == "delete-frame") {
        fs::remove(frame);
      } else {
        io::WriteFileAtomically(frame, io::ReadFileBytes(frame) + "x");
      }
    } else if (fault == "garbage") {
      for (const std::string& endpoint : {c.workers, c.control}) {
        zmq::socket_t peer(context, zmq::socket_type::dealer);
        peer.set(zmq::sockopt::linger, 0);
        peer.connect(endpoint);
        for (int k = 0; k < 1000; ++k) {
          std::string bytes(1 + rng() % 300, '\0');
          for (auto& b : bytes) b = char(rng());
          peer.send(zmq::buffer(bytes), zmq::send_flags::dontwait);
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
    }
    // Wait for the end; a master restarting may not answer for a moment.
    std::string state = "running";
    const auto end = Clock::now() + std::chrono::seconds(120);
    while (Clock::now() < end) {
      try {
        runtime::ControlRequest st;
        st.mutable_status()->set_session_id(id);
        state = client::Request(&context, c.control, st, 5000).sessions(0).state();
        if (state != "running") break;
      } catch (const std::exception&) {
        // restarting
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ++ends[fault][state];
    if (state == "running") ++left_running;
    bool keep = false;
    if (state == "done") {
      const auto got = client::SessionOutputFiles(session_out);
      if (got != expected) {
        ++differing;
        keep = true;  // left for a look
        std::string files;
        for (const auto& [rel, bytes] : expected) {
          auto it = got.find(rel);
          if (it == got.end() || it->second != bytes) files += " " + rel;
        }
        for (const auto& [rel, bytes] : got) {
          if (!expected.count(rel)) files += " +" + rel;
        }
        std::fprintf(stderr,
                     "soak_bench: session %d %s (%s) done with other outputs:%s (kept in %s)\n", i,
                     id.c_str(), fault.c_str(), files.c_str(), session_out.c_str());
      }
    }
    if (mounted) ::umount2(disk.c_str(), MNT_DETACH);
    fs::remove_all(copy);
    if (!mounted && !keep) fs::remove_all(session_out);
    const double rss = bench::ProcessRssMb(c.master);
    const bool counts = ++c.master_sessions > warmup;
    if (counts) counted_rss.push_back(rss);
    rss_log << "{\"session\": " << i << ", \"fault\": \"" << fault << "\", \"state\": \"" << state
            << "\", \"master_pid\": " << c.master << ", \"master_sessions\": " << c.master_sessions
            << ", \"rss_mb\": " << rss << ", \"counts\": " << (counts ? "true" : "false") << "}\n";
    rss_log.flush();
  }
  // Medians of the first and last 10 readings that count (fewer when there are fewer).
  auto median = [](std::vector<double> v) {
    if (v.empty()) return -1.0;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  const size_t n = std::min<size_t>(10, counted_rss.size());
  const double rss_before =
      median(std::vector<double>(counted_rss.begin(), counted_rss.begin() + long(n)));
  const double rss_after =
      median(std::vector<double>(counted_rss.end() - long(n), counted_rss.end()));
  const double growth = rss_before > 0 ? rss_after / rss_before - 1.0 : 0.0;
  const double seconds = std::chrono::duration<double>(Clock::now() - soak_start).count();
  for (pid_t w : c.worker_pids) Stop(w);
  Stop(c.master);
  std::string by_fault;
  for (const auto& [fault, states] : ends) {
    std::string inner;
    for (const auto& [state, n] : states) {
      inner += (inner.empty() ? "" : ", ") + std::string("\"") + state + "\": " + std::to_string(n);
    }
    by_fault += (by_fault.empty() ? "" : ", ") + std::string("\"") + fault + "\": {" + inner + "}";
  }
  std::printf(
      "{\"sessions\": %d, \"seconds\": %.1f, \"by_fault\": {%s}, \"left_running\": %d, "
      "\"done_with_other_outputs\": %d, \"master_rss_mb_before\": %.1f, "
      "\"master_rss_mb_after\": %.1f, \"master_rss_growth\": %.3f, \"rss_readings\": %zu, "
      "\"warmup_sessions\": %d}\n",
      sessions, seconds, by_fault.c_str(), left_running, differing, rss_before, rss_after, growth,
      counted_rss.size(), warmup);
  const bool rss_ok = rss_check < 0 || growth <= rss_check;
  return left_running == 0 && differing == 0 && rss_ok ? 0 : 1;
}
