// The master's blobs by content address (SHA-256 hex): take files are served from
// where they lie; job outputs are kept under OUT/.blobs/<sha256> so a restarted master
// finds them again (journal.h). Thread-safe (the surface stage runs beside the loop).
#pragma once

#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "runtime.pb.h"

namespace dome::scheduler {

class BlobStore {
 public:
  // Hashes the file and remembers its path. Throws core::InputError naming the file.
  runtime::BlobRef AddFile(const std::filesystem::path& path, const std::string& name);
  // Writes the bytes to dir/<sha256> (atomically, unless already there) and remembers.
  runtime::BlobRef AddBytes(const std::filesystem::path& dir, const std::string& bytes,
                            const std::string& name);
  // Remembers dir/<sha256> written by an earlier master (journal resume); false when
  // the file is not there or does not hash to `sha256`.
  bool Adopt(const std::filesystem::path& dir, const std::string& sha256);
  // The bytes, checked against their address: nothing when the blob is unknown, or
  // when its file is gone, unreadable or no longer hashes to `sha256` (a take file
  // deleted or replaced since it was added); then *error, when given, names the file
  // and what happened ("" for an unknown blob).
  std::optional<std::string> Read(const std::string& sha256, std::string* error) const;
  std::optional<runtime::BlobRef> Find(const std::string& sha256) const;
  // Lets go of one output held under these bytes (one AddBytes or Adopt); the last one
  // forgets the blob and removes the files the store wrote for it.
  void Drop(const std::string& sha256);
  // Forgets a blob and leaves its files alone (the outputs of a session that ended stay
  // in its folder for a later resume, its take files where they are): the next session
  // that reads or writes these bytes adds them again.
  void Forget(const std::string& sha256);
  // Blobs remembered (count).
  size_t size() const;

 private:
  struct Entry {
    // Where the bytes lie: an output's one file, or every take file added with these
    // bytes, most recent last (two takes share a rig; one may go while the other runs).
    std::vector<std::filesystem::path> paths;
    uint64_t size = 0;
    std::string name;
    bool owned = false;  // written by AddBytes: removed by Drop
    // Outputs held under these bytes (AddBytes and Adopt calls not yet dropped): two
    // outputs may be the same bytes (an empty slab of two instants), and the first one
    // dropped must not take the other's.
    int refs = 0;
  };
  // One more output held under `sha256` at `path` (mutex_ held).
  void Hold(const std::string& sha256, const std::filesystem::path& path, uint64_t size,
            const std::string& name);

  mutable std::mutex mutex_;
  std::map<std::string, Entry> entries_;
};

}  // namespace dome::scheduler
