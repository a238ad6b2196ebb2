// The session journal (SPEC.md "Nothing lost"): OUT/journal.log, append-only text,
// one record per line, each line fsync'd before the master acts on it, so a master
// killed at any moment and restarted on the same session resumes without redoing a
// finished job.
//
//   dome-journal 1 <session digest>        first line: the format version and the
//                                          SHA-256 of the session's resolved options
//   done <job key> [<name>=<sha256> ...]   a job finished; its outputs' blob addresses
//
// Job keys are "<instant>/<stage>/<part>" (no session id: a restarted master gives the
// session a new id). A torn last line (the master died mid-write) is cut away. A
// journal of another session digest is moved aside to journal.log.old and a new one
// started.
#pragma once

#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace dome::scheduler {

struct JournalEntry {
  std::vector<std::pair<std::string, std::string>> outputs;  // name, sha256
};

class Journal {
 public:
  // Opens (creating) `path` for the session with `digest`; the finished jobs already
  // recorded are in done(). Throws core::InputError naming the file when it cannot be
  // read or written.
  Journal(const std::filesystem::path& path, const std::string& digest);
  ~Journal();
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;

  const std::map<std::string, JournalEntry>& done() const { return done_; }

  // Appends a record and fsyncs it.
  void RecordDone(const std::string& key, const JournalEntry& entry);

 private:
  void Append(const std::string& line);

  std::filesystem::path path_;
  int fd_ = -1;
  std::map<std::string, JournalEntry> done_;
};

}  // namespace dome::scheduler
