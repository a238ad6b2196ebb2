// Test helper: dome's executables as child processes (fork/exec), output to a log
// file, signalled and reaped by pid.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "io/file_util.h"

namespace dome::testing {

class ChildProcess {
 public:
  // Starts build/bin/<binary> with `args`, stdout and stderr to `log`.
  ChildProcess(const std::string& binary, const std::vector<std::string>& args,
               const std::string& log)
      : log_(log) {
    const std::string path = std::string(DOME_BINARY_DIR) + "/bin/" + binary;
    pid_ = ::fork();
    if (pid_ == 0) {
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      if (fd >= 0) {
        ::dup2(fd, 1);
        ::dup2(fd, 2);
      }
      std::vector<char*> argv;
      argv.push_back(const_cast<char*>(path.c_str()));
      for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      ::execv(path.c_str(), argv.data());
      ::_exit(127);
    }
  }
  ~ChildProcess() {
    if (pid_ > 0 && !reaped_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return pid_; }
  void Signal(int sig) { ::kill(pid_, sig); }
  // Sends SIGKILL and reaps.
  void Kill() {
    Signal(SIGKILL);
    Wait();
  }
  // Waits for exit; returns the exit code, or -1 when killed by a signal.
  int Wait() {
    if (reaped_) return status_;
    int st = 0;
    ::waitpid(pid_, &st, 0);
    reaped_ = true;
    status_ = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return status_;
  }
  // Stops with SIGTERM (a clean shutdown), SIGKILL after `grace`.
  int Stop(std::chrono::milliseconds grace = std::chrono::milliseconds(3000)) {
    if (reaped_) return status_;
    Signal(SIGTERM);
    const auto end = std::chrono::steady_clock::now() + grace;
    while (std::chrono::steady_clock::now() < end) {
      int st = 0;
      if (::waitpid(pid_, &st, WNOHANG) == pid_) {
        reaped_ = true;
        status_ = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
        return status_;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    Kill();
    return status_;
  }
  std::string Log() const {
    try {
      return io::ReadFileBytes(log_);
    } catch (...) {
      return "";
    }
  }

 private:
  std::string log_;
  pid_t pid_ = -1;
  bool reaped_ = false;
  int status_ = -1;
};

}  // namespace dome::testing
