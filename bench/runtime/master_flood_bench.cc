// The resident memory of a dome-master process under abuse, round after round:
//
//   master_flood_bench [--rounds 5] [--warmup 0] [--subscriptions 10000] [--peers 100]
//                      [--topic-bytes 10240] [--fuzz 13000] [--check-mb 5]
//
// Starts bin/dome-master (beside this binary; plaintext, loopback, free ports, its
// default message cap). Each round connects --peers subscribers to the events port
// (net/events.h) that send --subscriptions subscriptions (Heartbeats) in all and one
// message of --topic-bytes each (over the socket's cap: the master drops the
// connection, the peer reconnects), waits until the master holds them, disconnects
// them, then sends --fuzz malformed messages to the worker and control ports from
// DEALERs that then disconnect: mostly short garbage, every 100th 5 MB (a result's
// size, under the cap: received whole, then refused as not an envelope). Before the
// first round and after each it prints the master's VmRSS from /proc as one JSON line
// (after a round: the least over the 6 s that follow, in which the master returns its
// freed memory to the system once or twice).
//
// With --check-mb M it exits 1 when the RSS after any counted round exceeds the RSS before
// the first round by more than M MB: what peers send must not stay in the
// master after they are gone, neither growing round after round nor held at a burst's
// peak. --warmup W runs W rounds first that the check does not count (more abuse
// before the counted rounds; the reference stays the master before any round).
// An amount, not a fraction of the master's size at start: that size is mostly the
// shared libraries it maps, which say nothing of what it keeps (17.6 MB since it no
// longer loads OpenCV's image codecs, 51 MB before; 5 MB was 10 % of the latter). One
// 5 MB message kept, or the flood's 20 MB of topics, exceeds it.
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>
#include <zmq.hpp>

#include "io/file_util.h"
#include "net/wire.h"
#include "process_rss.h"

namespace fs = std::filesystem;
using namespace dome;

namespace {

std::string Flag(int argc, char** argv, const std::string& name, const std::string& fallback) {
  for (int i = 1; i + 1 < argc; ++i) {
    if (name == argv[i]) return argv[i + 1];
  }
  return fallback;
}

void Subscribe(zmq::context_t* context, const std::string& events, int count, int peers,
               int topic_bytes) {
  std::vector<std::unique_ptr<zmq::socket_t>> subs;
  for (int s = 0; s < peers; ++s) {
    subs.push_back(std::make_unique<zmq::socket_t>(*context, zmq::socket_type::dealer));
    subs.back()->set(zmq::sockopt::linger, 0);
    subs.back()->set(zmq::sockopt::sndhwm, 0);
    subs.back()->connect(events);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  runtime::Envelope hb;
  hb.mutable_heartbeat();
  const std::string subscribe = net::EncodeEnvelope(hb);
  for (int i = 0; i < count; ++i) {
    subs[size_t(i % peers)]->send(zmq::buffer(subscribe), zmq::send_flags::dontwait);
  }
  const std::string topic(size_t(topic_bytes), 'x');
  for (auto& s : subs) s->send(zmq::buffer(topic), zmq::send_flags::dontwait);
  // The subscriptions travel to the master while these sockets live.
  std::this_thread::sleep_for(std::chrono::seconds(2));
}

// What Fuzz saw: the messages sent, those the master answered (a Refusal each) and the
// seconds from the first sent to the last answered.
struct FuzzOutcome {
  int sent = 0, answered = 0;
  double seconds = 0;
};

// Sends `count` malformed messages and waits until the master has answered each (it
// refuses every one with a Refusal on the same connection), at most `wait_s`: a master
// slowed by a loaded machine may hold a backlog of them for seconds, which is not
// what stays once it has read them.
FuzzOutcome Fuzz(zmq::context_t* context, const std::string& workers, const std::string& control,
                 int count, double wait_s) {
  std::vector<std::unique_ptr<zmq::socket_t>> peers;
  for (const std::string& endpoint : {workers, control}) {
    for (int p = 0; p < 4; ++p) {
      peers.push_back(std::make_unique<zmq::socket_t>(*context, zmq::socket_type::dealer));
      peers.back()->set(zmq::sockopt::linger, 0);
      peers.back()->set(zmq::sockopt::sndhwm, 0);
      peers.back()->connect(endpoint);
    }
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const auto start = std::chrono::steady_clock::now();
  FuzzOutcome out;
  uint64_t state = 88172645463325252ull;
  for (int i = 0; i < count; ++i) {
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    // Mostly short garbage, every 100th 5 MB (a result's size: under the cap).
    std::string bytes(i % 100 == 0 ? 5000000 : 16 + state % 2000, char(state));
    for (size_t k = 0; k < bytes.size() && k < 64; ++k) bytes[k] = char(state >> (k % 56));
    if (peers[size_t(i) % peers.size()]->send(zmq::buffer(bytes), zmq::send_flags::dontwait)) {
      ++out.sent;
    }
  }
  std::vector<zmq::pollitem_t> items;
  for (auto& p : peers) items.push_back({p->handle(), 0, ZMQ_POLLIN, 0});
  const auto deadline = start + std::chrono::duration<double>(wait_s);
  while (out.answered < out.sent && std::chrono::steady_clock::now() < deadline) {
    zmq::poll(items, std::chrono::milliseconds(100));
    for (auto& p : peers) {
      zmq::message_t reply;
      while (p->recv(reply, zmq::recv_flags::dontwait)) ++out.answered;
    }
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  const int counted = std::stoi(Flag(argc, argv, "--rounds", "5"));
  const int warmup = std::stoi(Flag(argc, argv, "--warmup", "0"));
  const int rounds = counted + warmup;
  const int subscriptions = std::stoi(Flag(argc, argv, "--subscriptions", "10000"));
  const int topic_bytes = std::stoi(Flag(argc, argv, "--topic-bytes", "10240"));
  const int peers = std::max(1, std::stoi(Flag(argc, argv, "--peers", "100")));
  const int fuzz = std::stoi(Flag(argc, argv, "--fuzz", "13000"));
  const double check_mb = std::stod(Flag(argc, argv, "--check-mb", "-1"));
  const fs::path dir = fs::temp_directory_path() / ("dome_flood_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path endpoints = dir / "endpoints";
  const std::string master = (fs::path(argv[0]).parent_path() / "dome-master").string();
  std::vector<std::string> args = {master,
                                   "--bind",
                                   "tcp://127.0.0.1:*",
                                   "--control",
                                   "tcp://127.0.0.1:*",
                                   "--events",
                                   "tcp://127.0.0.1:*",
                                   "--insecure",
                                   "--log-level",
                                   "error",
                                   "--endpoints-file",
                                   endpoints.string()};
  std::vector<char*> argv_master;
  for (auto& a : args) argv_master.push_back(a.data());
  argv_master.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawn(&pid, master.c_str(), nullptr, nullptr, argv_master.data(), environ) != 0) {
    std::fprintf(stderr, "master_flood_bench: cannot start %s\n", master.c_str());
    return 2;
  }
  for (int i = 0; i < 500 && !fs::exists(endpoints); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::string workers, control, events;
  std::istringstream(io::ReadFileBytes(endpoints)) >> workers >> control >> events;
  zmq::context_t context;
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  std::vector<double> rss = {bench::ProcessRssMb(pid)};
  std::printf("{\"round\": 0, \"rss_mb\": %.1f}\n", rss.back());
  for (int r = 1; r <= rounds; ++r) {
    Subscribe(&context, events, subscriptions, peers, topic_bytes);
    const double held = bench::ProcessRssMb(pid);  // before the subscribers go
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));
    const FuzzOutcome fuzzed = Fuzz(&context, workers, control, fuzz, 300);
    // What stays: the least RSS over the 6 s after the master answered the last message
    // (it returns freed memory to the system every 5 s).
    double least = bench::ProcessRssMb(pid);
    for (int i = 0; i < 12; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
      least = std::min(least, bench::ProcessRssMb(pid));
    }
    rss.push_back(least);
    std::printf(
        "{\"round\": %d, \"rss_mb_while_subscribed\": %.1f, \"rss_mb\": %.1f, "
        "\"subscriptions\": %d, \"topic_bytes\": %d, \"fuzz_messages\": %d, "
        "\"fuzz_answered\": %d, \"fuzz_answered_in_s\": %.1f}\n",
        r, held, rss.back(), subscriptions, topic_bytes, fuzzed.sent, fuzzed.answered,
        fuzzed.seconds);
    std::fflush(stdout);
  }
  ::kill(pid, SIGTERM);
  int status = 0;
  ::waitpid(pid, &status, 0);
  fs::remove_all(dir);
  if (check_mb >= 0 && counted >= 1) {
    // The most the master kept after a counted round, against the master before any.
    const double before = rss[0];
    const double most = *std::max_element(rss.begin() + 1 + warmup, rss.end());
    const double growth_mb = most - before;
    std::printf(
        "{\"rss_mb_before\": %.1f, \"rss_mb_most_after_a_round\": %.1f, \"growth_mb\": %.1f, "
        "\"warmup_rounds\": %d, \"counted_rounds\": %d, \"limit_mb\": %.1f}\n",
        before, most, growth_mb, warmup, counted, check_mb);
    if (growth_mb > check_mb) return 1;
  }
  return 0;
}
