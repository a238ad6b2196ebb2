// The session journal (SPEC.md "Nothing lost"): OUT/journal.log, append-only text,
// one record per line, so a master killed at any moment and restarted on the same
// session resumes without redoing a finished job.
//
// Each record is written to the file at once (a killed master loses nothing: the
// kernel holds it) and made durable in groups: Sync() fsyncs every record appended
// since the last one, and the master calls it every 50 ms of its loop, before it drops
// an instant's slabs and when a session ends, instead of once per record (one fsync
// costs milliseconds). A machine that loses power may lose the last 50 ms of records;
// their jobs are then redone, which is harmless as jobs are idempotent and their
// outputs content-addressed.
//
//   dome-journal 2 <session digest>        first line: the format version and the
//                                          SHA-256 of the session's resolved options
//   done <job key> [@<inputs>] [<name>=<sha256> ...]
//                                          a job finished: the digest of the inputs it
//                                          was made from (pipeline::InstantInputsDigest:
//                                          the rig's and its instant's frames' content
//                                          addresses), its outputs' blob addresses
//
// The master counts a record as done only while its inputs digest is the instant's
// current one: frames changed on disk since (the same take path, other bytes) redo
// that instant's jobs, and only those.
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
  std::string inputs{};  // digest of the inputs the job was made from; empty: none recorded
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

  // Appends a record (written, not yet fsync'd: see Sync). Throws core::StorageError
  // naming the file when it cannot be written (disk full); a part written is cut away
  // and the record is not in done().
  void RecordDone(const std::string& key, const JournalEntry& entry);
  // Fsyncs the records appended since the last call; a no-op when there are none.
  // Throws core::StorageError naming the file when the system cannot.
  void Sync();
  // Records appended and not yet fsync'd.
  int unsynced() const { return unsynced_; }

 private:
  void Append(const std::string& line);  // written, unsynced

  std::filesystem::path path_;
  int fd_ = -1;
  int unsynced_ = 0;
  std::map<std::string, JournalEntry> done_;
};

}  // namespace dome::scheduler
