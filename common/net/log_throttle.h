// Log lines about network peers, throttled: a peer that repeats a mistake (a refused
// handshake every reconnect interval, a flood of malformed messages) gets one line per
// key (a peer and its cause) every ten seconds, with the count of the ones left out.
// Not thread-safe: one per thread that logs.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>

namespace dome::net {

class LogThrottle {
 public:
  // The repeats of `key` since its last line, or nothing when it is too soon for one.
  std::optional<int64_t> ShouldLog(const std::string& key) {
    const auto now = std::chrono::steady_clock::now();
    auto [it, fresh] = logged_.try_emplace(key, Logged{now, 0});
    if (!fresh && now - it->second.last < kLogEvery) {
      ++it->second.since;
      return std::nullopt;
    }
    const int64_t n = it->second.since;
    it->second = Logged{now, 0};
    if (logged_.size() > 10000) logged_.clear();  // bounded, whatever the peers do
    return n;
  }
  // " (N more ... since the last line)" for n > 0, else "".
  static std::string Repeats(int64_t n, const std::string& what = "refusals") {
    return n > 0 ? " (" + std::to_string(n) + " more " + what + " since the last line)" : "";
  }

 private:
  static constexpr std::chrono::seconds kLogEvery{10};
  struct Logged {
    std::chrono::steady_clock::time_point last;
    int64_t since = 0;
  };
  std::map<std::string, Logged> logged_;
};

}  // namespace dome::net
