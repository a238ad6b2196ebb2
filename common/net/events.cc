#include "net/events.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <vector>

#include "core/error.h"
#include "net/wire.h"

namespace dome::net {

using Clock = std::chrono::steady_clock;

EventSubscribers::EventSubscribers(zmq::socket_t* socket) : socket_(socket) {
  socket_->set(zmq::sockopt::router_mandatory, 1);
  const int64_t cap = socket_->get(zmq::sockopt::maxmsgsize);
  max_bytes_ = cap > 0 ? cap : int64_t{1} << 20;
}

void EventSubscribers::Receive(int budget) {
  for (int i = 0; i < budget; ++i) {
    std::vector<zmq::message_t> frames = ReceiveFrames(socket_);
    if (frames.empty()) return;
    const std::string id = frames[0].to_string();
    std::string refused;
    if (frames.size() != 2) {
      refused = PeerName(id) + ": a message of " + std::to_string(frames.size() - 1) + " frames";
    } else {
      try {
        const runtime::Envelope env =
            DecodeEnvelope(frames[1].to_string_view(), PeerName(id), max_bytes_);
        if (env.has_heartbeat()) {
          const bool fresh =
              subscribers_
                  .insert_or_assign(id, Clock::now() + std::chrono::milliseconds(kEventsExpiryMs))
                  .second;
          if (fresh) {
            spdlog::debug("events: {} subscribed ({} subscribers)", PeerName(id),
                          subscribers_.size());
          }
          continue;
        }
        if (env.has_disconnect()) {
          Forget(id, "said Disconnect");
          continue;
        }
        refused = PeerName(id) + ": a " +
                  env.GetDescriptor()->FindFieldByNumber(env.body_case())->name() + " message";
      } catch (const core::InputError& e) {
        refused = e.what();
      }
    }
    if (auto n = log_.ShouldLog(id)) {
      spdlog::warn(
          "events: refused {} (a subscriber sends Heartbeat or Disconnect only; it holds one "
          "subscription, to every event, whatever else it sends){}",
          refused, LogThrottle::Repeats(*n));
    }
  }
}

void EventSubscribers::Publish(const runtime::Envelope& envelope) {
  if (subscribers_.empty()) return;
  const std::string bytes = EncodeEnvelope(envelope);
  std::vector<std::string> gone;
  for (const auto& [id, expiry] : subscribers_) {
    try {
      SendFrames(socket_, {id, bytes});  // false: its queue is full; it misses this one
    } catch (const zmq::error_t&) {
      gone.push_back(id);  // router_mandatory: the peer disconnected
    }
  }
  for (const auto& id : gone) Forget(id, "disconnected");
}

void EventSubscribers::Expire() {
  const auto now = Clock::now();
  std::vector<std::string> silent;
  for (const auto& [id, expiry] : subscribers_) {
    if (now > expiry) silent.push_back(id);
  }
  for (const auto& id : silent) Forget(id, "silent for 10 s");
}

void EventSubscribers::Forget(const std::string& id, const char* why) {
  if (subscribers_.erase(id) == 0) return;
  spdlog::debug("events: {} {}: forgotten ({} subscribers)", PeerName(id), why,
                subscribers_.size());
}

EventSubscription::EventSubscription(zmq::context_t* context, const std::string& endpoint,
                                     const SocketOptions& options)
    : socket_(*context, zmq::socket_type::dealer),
      endpoint_(endpoint),
      max_bytes_(options.max_message_bytes) {
  ConfigureSocket(&socket_, options);
  // Refreshes queue only while connected, a few at most: a master away for minutes
  // gets one or two when it is back, not a burst of all those missed.
  socket_.set(zmq::sockopt::immediate, 1);
  socket_.set(zmq::sockopt::sndhwm, 4);
  socket_.set(zmq::sockopt::linger, 100);
  try {
    socket_.connect(endpoint);
  } catch (const zmq::error_t& e) {
    throw core::InputError("status " + endpoint, std::string("cannot connect: ") + e.what());
  }
  next_refresh_ = Clock::now();
  Refresh();
}

EventSubscription::~EventSubscription() {
  runtime::Envelope bye;
  bye.mutable_disconnect();
  SendFrames(&socket_, {EncodeEnvelope(bye)});
}

void EventSubscription::Refresh() {
  // Until the connection is up (immediate), a send would block: try again soon.
  runtime::Envelope hb;
  hb.mutable_heartbeat();
  const bool sent = SendFrames(&socket_, {EncodeEnvelope(hb)});
  next_refresh_ = Clock::now() + std::chrono::milliseconds(sent ? kEventsRefreshMs : 20);
}

void EventSubscription::Drain(int wait_ms,
                              const std::function<void(const runtime::StatusEvent&)>& on_event,
                              const bool* stop_when) {
  const auto end = Clock::now() + std::chrono::milliseconds(wait_ms);
  while (true) {
    if (Clock::now() >= next_refresh_) Refresh();
    const auto now = Clock::now();
    const auto until = std::min(end, next_refresh_);
    const int ms = int(std::chrono::duration_cast<std::chrono::milliseconds>(until - now).count());
    WaitForInput(&socket_, std::max(ms, 0));
    zmq::message_t m;
    while (socket_.recv(m, zmq::recv_flags::dontwait)) {
      runtime::Envelope env;
      try {
        env = DecodeEnvelope(m.to_string_view(), "status " + endpoint_, max_bytes_);
      } catch (const core::InputError&) {
        continue;
      }
      if (env.has_status()) on_event(env.status());
    }
    if (Clock::now() >= end || (stop_when != nullptr && *stop_when)) return;
  }
}

}  // namespace dome::net
