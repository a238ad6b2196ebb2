#include "core/wake_pipe.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

#include "core/error.h"

namespace dome::core {

WakePipe::WakePipe(const char* owner) {
  if (pipe2(fds_, O_NONBLOCK | O_CLOEXEC) != 0) {
    throw InputError(owner, std::string("cannot make a wake pipe: ") + std::strerror(errno));
  }
}

WakePipe::~WakePipe() {
  for (int fd : fds_) close(fd);
}

void WakePipe::Wake() {
  const char byte = 1;
  [[maybe_unused]] const ssize_t n = write(fds_[1], &byte, 1);
}

void WakePipe::Drain() {
  char bytes[64];
  while (read(fds_[0], bytes, sizeof bytes) > 0) {
  }
}

}  // namespace dome::core
