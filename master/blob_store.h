// The master's blobs by content address (SHA-256 hex): take files are served from
// where they lie; job outputs are kept under OUT/.blobs/<sha256> so a restarted master
// finds them again (journal.h). Thread-safe (the surface stage runs beside the loop).
#pragma once

#include <cstddef>
#include <filesystem>
#include <list>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "runtime.pb.h"

namespace dome::scheduler {

// The budget of BlobStore's recent outputs, bytes: a one-instant Robovision run's stereo
// outputs (63 MB), slabs and mesh; two instants' stereo outputs of Panoptic's five HD
// cameras (33 MB an instant) or of the paper take's 51 cameras (30 MB). The master's peak
// memory grows by up to this much.
inline constexpr size_t kRecentOutputBytes = size_t(128) << 20;

class BlobStore {
 public:
  // recent_bytes: the budget of outputs served from memory (Read).
  explicit BlobStore(size_t recent_bytes = kRecentOutputBytes) : recent_budget_(recent_bytes) {}
  // Hashes the file and remembers its path. Throws core::InputError naming the file.
  runtime::BlobRef AddFile(const std::filesystem::path& path, const std::string& name);
  // Writes the bytes to dir/<sha256> (atomically, unless already there) and remembers.
  // With `copy_of`, a file that holds exactly these bytes (an output file just written
  // beside dir): dir/<sha256> becomes a second name of it (a hard link) instead of a
  // second copy, unless the file system refuses (then the bytes are written). The blob
  // keeps the bytes when that file is later replaced (io::WriteFileAtomically renames a
  // new file over the name) or deleted; one changed in place is caught by the hashes of
  // Read and Adopt.
  runtime::BlobRef AddBytes(const std::filesystem::path& dir, const std::string& bytes,
                            const std::string& name, const std::filesystem::path& copy_of = {});
  // Remembers dir/<sha256> written by an earlier master (journal resume); false when
  // the file is not there or does not hash to `sha256`.
  bool Adopt(const std::filesystem::path& dir, const std::string& sha256);
  // The bytes, checked against their address: nothing when the blob is unknown, or
  // when its file is gone, unreadable or no longer hashes to `sha256` (a take file
  // deleted or replaced since it was added); then *error, when given, names the file
  // and what happened ("" for an unknown blob).
  // An output among the last recent_bytes added is served from memory, without reading
  // its file back or hashing it again.
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

  // Keeps the bytes of an output just added, dropping the oldest past the budget
  // (mutex_ held).
  void Remember(const std::string& sha256, const std::string& bytes);
  void Unremember(const std::string& sha256);  // mutex_ held

  mutable std::mutex mutex_;
  std::map<std::string, Entry> entries_;
  // The bytes of the outputs added last, oldest first, recent_budget_ at most in all.
  // A stage's outputs are the next stage's inputs, asked for by every worker that runs one
  // of its jobs: each time read from the file and hashed on the master's loop before
  // (Robovision's twelve stereo outputs, 63 MB, went to both of `dome run`'s workers for
  // fusion).
  std::list<std::pair<std::string, std::string>> recent_;  // (sha256, bytes)
  std::map<std::string, decltype(recent_)::iterator> recent_at_;
  size_t recent_bytes_ = 0;
  size_t recent_budget_;
};

}  // namespace dome::scheduler
