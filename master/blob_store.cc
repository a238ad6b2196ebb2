#include "master/blob_store.h"

#include <algorithm>

#include "core/error.h"
#include "io/file_util.h"
#include "net/content_hash.h"

namespace dome::scheduler {
namespace fs = std::filesystem;

namespace {
constexpr size_t kPathsPerBlob = 4;  // take files kept per blob (AddFile)
}  // namespace

runtime::BlobRef BlobStore::AddFile(const fs::path& path, const std::string& name) {
  const std::string bytes = io::ReadFileBytes(path);
  runtime::BlobRef ref;
  ref.set_sha256(net::Sha256Hex(bytes));
  ref.set_size(bytes.size());
  ref.set_name(name);
  std::lock_guard<std::mutex> lock(mutex_);
  auto [it, fresh] = entries_.try_emplace(ref.sha256(), Entry{{path}, bytes.size(), name, false});
  if (!fresh && !it->second.owned) {
    // The few most recent files with these bytes: enough for takes that share a file,
    // bounded for a take whose frames are all the same bytes (a static scene).
    auto& paths = it->second.paths;
    paths.erase(std::remove(paths.begin(), paths.end(), path), paths.end());
    paths.push_back(path);
    if (paths.size() > kPathsPerBlob) paths.erase(paths.begin());
  }
  return ref;
}

runtime::BlobRef BlobStore::AddBytes(const fs::path& dir, const std::string& bytes,
                                     const std::string& name, const fs::path& copy_of) {
  runtime::BlobRef ref;
  ref.set_sha256(net::Sha256Hex(bytes));
  ref.set_size(bytes.size());
  ref.set_name(name);
  const fs::path path = dir / ref.sha256();
  std::error_code ec;
  if (!fs::exists(path, ec) || fs::file_size(path, ec) != bytes.size()) {
    fs::create_directories(dir, ec);
    // One copy on disk instead of two: a Robovision instant's surface (8 MB) and
    // textured files (9 MB) were each written twice, at the end of the instant where
    // the session waits on the master's writes.
    bool linked = false;
    if (!copy_of.empty()) {
      ec.clear();
      fs::create_hard_link(copy_of, path, ec);
      linked = !ec && fs::file_size(path, ec) == bytes.size() && !ec;
    }
    if (!linked) io::WriteFileAtomically(path, bytes);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  Hold(ref.sha256(), path, bytes.size(), name);
  Remember(ref.sha256(), bytes);
  return ref;
}

void BlobStore::Remember(const std::string& sha256, const std::string& bytes) {
  if (bytes.size() > recent_budget_ || recent_at_.count(sha256) != 0) return;
  recent_.emplace_back(sha256, bytes);
  recent_at_[sha256] = std::prev(recent_.end());
  recent_bytes_ += bytes.size();
  while (recent_bytes_ > recent_budget_) Unremember(recent_.front().first);
}

void BlobStore::Unremember(const std::string& sha256) {
  auto at = recent_at_.find(sha256);
  if (at == recent_at_.end()) return;
  recent_bytes_ -= at->second->second.size();
  recent_.erase(at->second);
  recent_at_.erase(at);
}

bool BlobStore::Adopt(const fs::path& dir, const std::string& sha256) {
  const fs::path path = dir / sha256;
  std::error_code ec;
  if (!net::IsSha256Hex(sha256) || !fs::exists(path, ec)) return false;
  std::string bytes;
  try {
    bytes = io::ReadFileBytes(path);
  } catch (const core::InputError&) {
    return false;
  }
  if (net::Sha256Hex(bytes) != sha256) return false;
  std::lock_guard<std::mutex> lock(mutex_);
  Hold(sha256, path, bytes.size(), sha256);
  return true;
}

std::optional<std::string> BlobStore::Read(const std::string& sha256, std::string* error) const {
  if (error) error->clear();
  std::vector<fs::path> paths;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = entries_.find(sha256);
    if (it == entries_.end()) return std::nullopt;
    // Hashed when it was added, and held here since.
    if (auto at = recent_at_.find(sha256); at != recent_at_.end()) return at->second->second;
    paths = it->second.paths;
  }
  // The most recent file first; any that still holds the bytes will do.
  std::string first_error;
  for (auto p = paths.rbegin(); p != paths.rend(); ++p) {
    std::string bytes;
    try {
      bytes = io::ReadFileBytes(*p);
    } catch (const core::InputError& e) {
      if (first_error.empty()) first_error = e.what();
      continue;
    }
    // Hashing what is served costs about a millisecond a megabyte; serving bytes under
    // an address they do not have would make every worker ask again without end.
    if (net::Sha256Hex(bytes) == sha256) return bytes;
    if (first_error.empty()) {
      first_error = p->string() +
                    ": changed since it was read at submit (its bytes no longer hash to " +
                    sha256.substr(0, 12) + "...)";
    }
  }
  if (error) *error = first_error;
  return std::nullopt;
}

std::optional<runtime::BlobRef> BlobStore::Find(const std::string& sha256) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = entries_.find(sha256);
  if (it == entries_.end()) return std::nullopt;
  runtime::BlobRef ref;
  ref.set_sha256(sha256);
  ref.set_size(it->second.size);
  ref.set_name(it->second.name);
  return ref;
}

void BlobStore::Hold(const std::string& sha256, const fs::path& path, uint64_t size,
                     const std::string& name) {
  Entry& e = entries_[sha256];
  if (!e.owned) e = Entry{{}, size, name, true, 0};  // an output's file replaces take files
  if (std::find(e.paths.begin(), e.paths.end(), path) == e.paths.end()) e.paths.push_back(path);
  ++e.refs;
}

void BlobStore::Drop(const std::string& sha256) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = entries_.find(sha256);
  if (it == entries_.end()) return;
  if (it->second.owned) {
    if (--it->second.refs > 0) return;
    std::error_code ec;
    for (const auto& path : it->second.paths) fs::remove(path, ec);
  }
  entries_.erase(it);
  Unremember(sha256);
}

void BlobStore::Forget(const std::string& sha256) {
  std::lock_guard<std::mutex> lock(mutex_);
  entries_.erase(sha256);
  Unremember(sha256);
}

size_t BlobStore::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return entries_.size();
}

}  // namespace dome::scheduler
