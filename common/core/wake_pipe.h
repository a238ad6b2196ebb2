// A pipe that wakes a thread blocked in poll(2) (or zmq::poll, as a raw descriptor) from
// another thread: Wake() writes a byte, the poller sees read_fd() readable and Drain()s
// it. Loops that poll their sockets with a timeout use it to act on work another
// thread finished at once, not when the timeout runs out.
//
// Wake() and Drain() are safe from any threads at once (writes and reads of a
// non-blocking pipe); a full pipe (bytes nobody drained) only drops the wake, which
// the next timeout covers.
#pragma once

namespace dome::core {

class WakePipe {
 public:
  // Throws core::InputError naming `owner` when the system gives no pipe.
  explicit WakePipe(const char* owner);
  ~WakePipe();
  WakePipe(const WakePipe&) = delete;
  WakePipe& operator=(const WakePipe&) = delete;

  int read_fd() const { return fds_[0]; }
  void Wake();
  void Drain();

 private:
  int fds_[2] = {-1, -1};
};

}  // namespace dome::core
