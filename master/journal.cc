#include "master/journal.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <sstream>

#include "core/error.h"
#include "io/file_util.h"

namespace dome::scheduler {
namespace fs = std::filesystem;

namespace {
// Version 2 added the inputs digest; a version 1 journal is moved aside like another
// session's (its jobs are redone: nothing says which inputs they were made from).
const char* kMagic = "dome-journal 2 ";
}  // namespace

Journal::Journal(const fs::path& path, const std::string& digest) : path_(path) {
  bool fresh = true;
  if (fs::exists(path)) {
    const std::string text = io::ReadFileBytes(path);
    std::istringstream in(text);
    std::string line;
    const bool complete = !text.empty() && text.back() == '\n';
    std::getline(in, line);
    if (line == kMagic + digest) {
      fresh = false;
      std::vector<std::string> lines;
      while (std::getline(in, line)) lines.push_back(line);
      if (!complete && !lines.empty()) lines.pop_back();  // torn last record
      for (const std::string& l : lines) {
        std::istringstream fields(l);
        std::string verb, key, output;
        fields >> verb >> key;
        if (verb != "done" || key.empty()) continue;
        JournalEntry entry;
        bool ok = true;
        while (fields >> output) {
          if (output.size() > 1 && output[0] == '@' && entry.inputs.empty() &&
              entry.outputs.empty()) {
            entry.inputs = output.substr(1);
            continue;
          }
          const auto eq = output.find('=');
          if (eq == std::string::npos) {
            ok = false;
            break;
          }
          entry.outputs.emplace_back(output.substr(0, eq), output.substr(eq + 1));
        }
        if (ok) done_[key] = std::move(entry);
      }
    } else {
      std::error_code ec;
      fs::rename(path, fs::path(path.string() + ".old"), ec);
      core::Require(!ec, path.string(), "cannot move an old journal aside: " + ec.message());
    }
  }
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    throw core::StorageError(path.string(),
                             std::string("cannot open the journal: ") + std::strerror(errno));
  }
  if (fresh) {
    Append(kMagic + digest + "\n");
    Sync();
  } else {
    // Cut a torn last record away, so that the next one starts on its own line and the
    // torn one never reads as complete.
    const std::string text = io::ReadFileBytes(path);
    if (!text.empty() && text.back() != '\n') {
      core::Require(::ftruncate(fd_, off_t(text.rfind('\n') + 1)) == 0, path.string(),
                    std::string("cannot cut a torn record: ") + std::strerror(errno));
    }
  }
}

Journal::~Journal() {
  if (fd_ < 0) return;
  try {
    Sync();
  } catch (const core::InputError&) {
    // Nothing to do about it here; the records are written, only not forced to disk.
  }
  ::close(fd_);
}

void Journal::Append(const std::string& line) {
  const off_t start = ::lseek(fd_, 0, SEEK_END);
  size_t written = 0;
  while (written < line.size()) {
    const ssize_t n = ::write(fd_, line.data() + written, line.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : ENOSPC;
      // A part of the record written would join the next one on its line: cut it away,
      // so that the journal stays whole records (a record lost only redoes its job).
      if (written > 0 && start >= 0) (void)::ftruncate(fd_, start);
      throw core::StorageError(path_.string(),
                               std::string("cannot append a record: ") + std::strerror(err));
    }
    written += size_t(n);
  }
  ++unsynced_;
}

void Journal::Sync() {
  if (unsynced_ == 0) return;
  if (::fdatasync(fd_) != 0) {
    throw core::StorageError(path_.string(), std::string("cannot fsync: ") + std::strerror(errno));
  }
  unsynced_ = 0;
}

void Journal::RecordDone(const std::string& key, const JournalEntry& entry) {
  std::string line = "done " + key;
  if (!entry.inputs.empty()) line += " @" + entry.inputs;
  for (const auto& [name, sha] : entry.outputs) line += " " + name + "=" + sha;
  Append(line + "\n");
  done_[key] = entry;
}

}  // namespace dome::scheduler
