// A master's status events (master/master.h "events"): the master's ROUTER sends each
// StatusEvent to every subscriber; a subscriber is a DEALER that subscribes by sending
// a Heartbeat envelope, and stays subscribed by sending one every kEventsRefreshMs.
//
// Why not PUB/SUB: ZeroMQ keeps every topic a SUB peer subscribes to in the publisher's
// subscription trie for as long as that peer stays connected, however many there are
// (10,000 distinct topics of 10 KB took about 650 MB), and no option bounds their count
// per peer. Status events carry no topic, so a subscription needs none: here a peer is
// one subscriber of a fixed size whatever it sends (anything but a Heartbeat or a
// Disconnect is refused, logged throttled), and it is freed when it disconnects (the
// next event sent to it finds it gone), says Disconnect, or falls silent for
// kEventsExpiryMs.
//
// Events are progress, best effort: a subscriber that does not read them loses those
// past its socket's high-water mark, as with PUB; the control socket is the source of
// truth.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <zmq.hpp>

#include "net/log_throttle.h"
#include "net/wire.h"
#include "runtime.pb.h"

namespace dome::net {

// A subscriber says Heartbeat this often, ms: on connecting, then to stay subscribed
// (and to be subscribed again by a master that restarted).
inline constexpr int kEventsRefreshMs = 1000;
// The master forgets a subscriber silent this long, ms: ten refreshes, so that a
// subscriber on a loaded machine or a slow link is not dropped between two of them.
inline constexpr int kEventsExpiryMs = 10 * kEventsRefreshMs;

// The master's side: the subscribers of its events ROUTER `socket` (bound and
// configured by the caller; router_mandatory is set here, so that a send to a peer
// that is gone says so). Not thread-safe: the master's loop owns it.
class EventSubscribers {
 public:
  explicit EventSubscribers(zmq::socket_t* socket);

  // Reads what peers sent (at most `budget` messages): a Heartbeat subscribes its peer
  // or keeps it subscribed, a Disconnect unsubscribes it, anything else is refused.
  void Receive(int budget = 1000);
  // Sends `envelope` to every subscriber; forgets the ones gone. A subscriber whose
  // queue is full misses it.
  void Publish(const runtime::Envelope& envelope);
  // Forgets the subscribers silent for kEventsExpiryMs.
  void Expire();
  size_t size() const { return subscribers_.size(); }

 private:
  void Forget(const std::string& id, const char* why);
  zmq::socket_t* socket_;
  int64_t max_bytes_;
  // Routing id -> when it is forgotten unless it refreshes.
  std::map<std::string, std::chrono::steady_clock::time_point> subscribers_;
  LogThrottle log_;
};

// A subscriber's side: a DEALER connected to the master's events endpoint.
class EventSubscription {
 public:
  // Connects and subscribes. Throws core::InputError naming the endpoint when it
  // cannot connect.
  EventSubscription(zmq::context_t* context, const std::string& endpoint,
                    const SocketOptions& options);
  // Says Disconnect (the master frees this subscriber at once).
  ~EventSubscription();
  EventSubscription(const EventSubscription&) = delete;
  EventSubscription& operator=(const EventSubscription&) = delete;

  // Waits up to wait_ms for events and hands each to on_event, refreshing the
  // subscription when it is due. Messages that do not decode are skipped. With `stop_when`,
  // returns after the events at hand once on_event has set *stop_when.
  void Drain(int wait_ms, const std::function<void(const runtime::StatusEvent&)>& on_event,
             const bool* stop_when = nullptr);
  zmq::socket_t& socket() { return socket_; }

 private:
  void Refresh();
  zmq::socket_t socket_;
  std::string endpoint_;
  int64_t max_bytes_;
  std::chrono::steady_clock::time_point next_refresh_;
};

}  // namespace dome::net
