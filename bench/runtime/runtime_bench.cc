// Runtime benchmarks (issue 8's scaling numbers). Prints one JSON line per mode.
//
//   runtime_bench dispatch OUT [--workers 32] [--jobs 4000]
//     The master's dispatch rate: an in-process Master on loopback TCP, `--workers`
//     dome-worker processes (bin/dome-worker beside this binary, one thread each,
//     plaintext), a session of no-op jobs; jobs/s from submit to the last result
//     (journal fsyncs included, as in a real session). OUT/noop holds its journal.
//   runtime_bench memory [--cameras 51] [--instants 1000] [--slabs 19]
//     The master's bookkeeping for a session of that shape: the job graph and one blob
//     reference per frame, as resident-memory growth of this process.
//   runtime_bench e2e TAKE OUT [--workers N] [--instants N] [--instant TC]...
//     `dome run` on the embedded cluster (N workers, one thread each) over the first N
//     instants of the take (default all) or the ones named; prints from the session's
//     report.json the seconds per instant, the bytes moved (OUT/report.json has them
//     per stage), the workers' utilisation (job seconds / (workers x wall seconds):
//     1 when a job runs on every worker all the time, whatever else loads the
//     machine), the master loop's busy fraction and longest turn, and the load average.
//   runtime_bench scaling TAKE OUT [--instants N] [--workers N]
//     e2e with 1 worker (OUT/w1), then with N (default 2, OUT/wN): the parallel
//     efficiency T1 / (N x TN), both runs' utilisation and CPU seconds (more CPU for
//     the same jobs with N workers is contention). On this 2-core machine, the whole
//     paper take (11 instants):
//       dome synth --preset paper --out TAKE && runtime_bench scaling TAKE OUT
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "cli/client.h"
#include "core/json.h"
#include "core/memory.h"
#include "io/file_util.h"
#include "master/graph.h"
#include "master/master.h"
#include "take/take.h"

using namespace dome;
namespace fs = std::filesystem;

namespace {

std::string Flag(int argc, char** argv, const std::string& name, const std::string& fallback) {
  for (int i = 1; i + 1 < argc; ++i) {
    if (name == argv[i]) return argv[i + 1];
  }
  return fallback;
}

int64_t ResidentKiB() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stoll(line.substr(6));
  }
  return -1;
}

// Worker processes of the dispatch benchmark, started with posix_spawn (no fork of a
// process whose ZeroMQ threads are running) and stopped with SIGTERM however the
// benchmark ends.
class WorkerProcesses {
 public:
  WorkerProcesses(const std::string& binary, const std::string& master, int count) {
    for (int w = 0; w < count; ++w) {
      std::vector<std::string> args = {binary,
                                       "--master",
                                       master,
                                       "--threads",
                                       "1",
                                       "--cache-mb",
                                       "16",
                                       "--log-level",
                                       "warn",
                                       "--name",
                                       "noop-" + std::to_string(w),
                                       "--insecure"};
      std::vector<char*> argv;
      for (auto& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      pid_t pid = -1;
      const int err = ::posix_spawn(&pid, binary.c_str(), nullptr, nullptr, argv.data(), environ);
      if (err != 0) {
        throw std::runtime_error("cannot start " + binary + ": " + std::strerror(err));
      }
      pids_.push_back(pid);
    }
  }
  ~WorkerProcesses() {
    for (pid_t pid : pids_) ::kill(pid, SIGTERM);
    for (pid_t pid : pids_) ::waitpid(pid, nullptr, 0);
  }

 private:
  std::vector<pid_t> pids_;
};

// The master's loop on its own thread, stopped and joined however the benchmark ends.
class MasterThread {
 public:
  explicit MasterThread(scheduler::Master* master)
      : thread_([this, master] { master->Run(&stop_); }) {}
  ~MasterThread() {
    stop_ = true;
    thread_.join();
  }

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

int Dispatch(const fs::path& out, int num_workers, int jobs, const fs::path& bin) {
  // A session's journal resumes finished jobs: start from nothing.
  fs::remove_all(out / "probe");
  fs::remove_all(out / "noop");
  zmq::context_t context;
  scheduler::MasterOptions mo;
  mo.worker_endpoint = mo.control_endpoint = mo.events_endpoint = "tcp://127.0.0.1:*";
  scheduler::Master master(&context, mo);
  const std::string control = master.endpoints().control;
  MasterThread loop(&master);
  WorkerProcesses workers((bin / "dome-worker").string(), master.endpoints().workers, num_workers);
  // Wait until every worker said Hello: a one-job session's status counts them.
  runtime::Session probe;
  probe.set_out((out / "probe").string());
  probe.set_noop_jobs(1);
  runtime::ControlRequest submit_probe;
  *submit_probe.mutable_submit()->mutable_session() = probe;
  const std::string probe_id = client::Request(&context, control, submit_probe).session_id();
  runtime::ControlRequest ask;
  ask.mutable_status()->set_session_id(probe_id);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  int seen = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    seen = client::Request(&context, control, ask).sessions(0).workers();
    if (seen >= num_workers) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  if (seen < num_workers) {
    std::fprintf(stderr, "runtime_bench: only %d of %d workers registered in 120 s\n", seen,
                 num_workers);
    return 1;
  }
  runtime::Session session;
  session.set_out((out / "noop").string());
  session.set_noop_jobs(jobs);
  runtime::ControlRequest req;
  *req.mutable_submit()->mutable_session() = session;
  const auto start = std::chrono::steady_clock::now();
  const auto reply = client::Request(&context, control, req);
  const auto status =
      client::WaitForSession(&context, control, "", reply.session_id(), nullptr, 20);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  core::PrintJsonLine({{"mode", "dispatch"},
                       {"workers", num_workers},
                       {"workers_seen", seen},
                       {"jobs", jobs},
                       {"state", status.state()},
                       {"seconds", seconds},
                       {"jobs_per_s", jobs / seconds}});
  return status.state() == "done" ? 0 : 1;
}

int Memory(int cameras, int instants, int slabs) {
  const int64_t before = ResidentKiB();
  std::vector<std::string> ids, times;
  for (int c = 0; c < cameras; ++c) ids.push_back("c" + std::to_string(c));
  for (int t = 0; t < instants; ++t) times.push_back("00-00-" + std::to_string(t));
  pipeline::SessionPlan plan;  // the default stages' graph of that many cameras and slabs
  plan.cameras = ids;
  plan.num_slabs = slabs;
  scheduler::JobGraph graph(times, scheduler::GraphStages(*pipeline::DefaultStages(), plan));
  std::vector<std::vector<runtime::BlobRef>> frames(instants);
  for (int t = 0; t < instants; ++t) {
    for (int c = 0; c < cameras; ++c) {
      runtime::BlobRef ref;
      ref.set_sha256(std::string(64, 'a' + c % 6));
      ref.set_size(250000);
      ref.set_name("frames/" + times[t] + "/" + ids[c] + ".png");
      frames[t].push_back(std::move(ref));
    }
  }
  const int64_t after = ResidentKiB();
  core::PrintJsonLine({{"mode", "memory"},
                       {"cameras", cameras},
                       {"instants", instants},
                       {"slabs", slabs},
                       {"jobs", graph.size()},
                       {"master_bookkeeping_mib", (after - before) / 1024.0}});
  return 0;
}

double LoadAverage() {
  std::ifstream in("/proc/loadavg");
  double one = 0;
  in >> one;
  return one;
}

struct EndToEndFigures {
  bool done = false;
  double seconds = 0, worker_job_seconds = 0;
  double cpu_seconds = 0;  // user + system of this process (master and workers) during the run
};

// User + system CPU seconds of this process so far.
double ProcessCpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// A number of report.json at `pointer` ("/master_loop/busy_fraction"), or NaN where it is
// absent or null.
double ReportNumber(const core::Json& report, const std::string& pointer) {
  const core::Json::json_pointer p(pointer);
  return report.contains(p) && report.at(p).is_number() ? report.at(p).get<double>() : std::nan("");
}

EndToEndFigures EndToEnd(const fs::path& take, const fs::path& out, int workers,
                         const std::vector<std::string>& instants) {
  // A session's journal resumes finished jobs: start from nothing.
  fs::remove_all(out);
  runtime::Session s;
  s.set_take(fs::absolute(take).string());
  s.set_out(fs::absolute(out).string());
  for (const auto& i : instants) s.add_instants(i);
  client::EmbeddedOptions e;
  e.workers = workers;
  e.threads_per_worker = 1;
  const double load_before = LoadAverage();
  const double cpu_before = ProcessCpuSeconds();
  const auto st = client::RunEmbedded(s, e, nullptr);
  const double cpu_seconds = ProcessCpuSeconds() - cpu_before;
  const double load_after = LoadAverage();
  const core::Json report = core::Json::parse(io::ReadFileBytes(out / "report.json"));
  EndToEndFigures f;
  f.done = st.state() == "done";
  f.cpu_seconds = cpu_seconds;
  f.seconds = ReportNumber(report, "/seconds");
  f.worker_job_seconds = ReportNumber(report, "/worker_job_seconds");
  core::PrintJsonLine(
      {{"mode", "e2e"},
       {"workers", workers},
       {"state", st.state()},
       {"instants", ReportNumber(report, "/instants")},
       {"seconds", f.seconds},
       {"seconds_per_instant", ReportNumber(report, "/seconds_per_instant")},
       {"worker_job_seconds", f.worker_job_seconds},
       {"utilisation", f.worker_job_seconds / (workers * f.seconds)},
       {"master_loop_busy_fraction", ReportNumber(report, "/master_loop/busy_fraction")},
       {"master_loop_longest_turn_s", ReportNumber(report, "/master_loop/longest_turn_s")},
       {"bytes_to_workers", ReportNumber(report, "/bytes_to_workers")},
       {"bytes_from_workers", ReportNumber(report, "/bytes_from_workers")},
       {"cpu_seconds", cpu_seconds},
       {"load_average", {load_before, load_after}}});
  return f;
}

// The instants of a bench run: those named, else the first `count` of the take (0: all).
std::vector<std::string> BenchInstants(const fs::path& take, const std::vector<std::string>& named,
                                       int count) {
  if (!named.empty() || count <= 0) return named;
  std::vector<std::string> all = take::OpenTake(take).instants;
  if (int(all.size()) > count) all.resize(size_t(count));
  return all;
}

int Scaling(const fs::path& take, const fs::path& out, int workers,
            const std::vector<std::string>& instants) {
  const EndToEndFigures one = EndToEnd(take, out / "w1", 1, instants);
  const EndToEndFigures many =
      EndToEnd(take, out / ("w" + std::to_string(workers)), workers, instants);
  const std::string n = std::to_string(workers);
  core::PrintJsonLine({{"mode", "scaling"},
                       {"workers", workers},
                       {"seconds_1", one.seconds},
                       {"seconds_" + n, many.seconds},
                       {"speedup", one.seconds / many.seconds},
                       {"parallel_efficiency", one.seconds / (workers * many.seconds)},
                       {"utilisation_1", one.worker_job_seconds / one.seconds},
                       {"utilisation_" + n, many.worker_job_seconds / (workers * many.seconds)},
                       {"cpu_seconds_1", one.cpu_seconds},
                       {"cpu_seconds_" + n, many.cpu_seconds}});
  return one.done && many.done ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  dome::core::RetainFreedMemory();
  if (argc < 2) {
    std::fprintf(stderr,
                 "usage: runtime_bench dispatch OUT | memory | e2e TAKE OUT | scaling TAKE OUT "
                 "[flags]\n");
    return 2;
  }
  const std::string mode = argv[1];
  const fs::path bin = fs::canonical("/proc/self/exe").parent_path();
  try {
    if (mode == "dispatch" && argc >= 3) {
      return Dispatch(argv[2], std::stoi(Flag(argc, argv, "--workers", "32")),
                      std::stoi(Flag(argc, argv, "--jobs", "4000")), bin);
    }
    if (mode == "memory") {
      return Memory(std::stoi(Flag(argc, argv, "--cameras", "51")),
                    std::stoi(Flag(argc, argv, "--instants", "1000")),
                    std::stoi(Flag(argc, argv, "--slabs", "19")));
    }
    if ((mode == "e2e" || mode == "scaling") && argc >= 4) {
      std::vector<std::string> named;
      for (int i = 4; i + 1 < argc; ++i) {
        if (std::strcmp(argv[i], "--instant") == 0) named.push_back(argv[i + 1]);
      }
      const std::vector<std::string> instants =
          BenchInstants(argv[2], named, std::stoi(Flag(argc, argv, "--instants", "0")));
      if (mode == "scaling") {
        return Scaling(argv[2], argv[3], std::stoi(Flag(argc, argv, "--workers", "2")), instants);
      }
      return EndToEnd(argv[2], argv[3], std::stoi(Flag(argc, argv, "--workers", "1")), instants)
                     .done
                 ? 0
                 : 1;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "runtime_bench: %s\n", e.what());
    return 1;
  }
  std::fprintf(stderr, "runtime_bench: unknown mode or missing arguments\n");
  return 2;
}
