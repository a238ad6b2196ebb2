#include "io/file_util.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <system_error>

#include "core/error.h"

namespace dome::io {
namespace {

std::string ErrnoText(int err) { return std::generic_category().message(err); }

// The folder shown in messages: "." rather than an empty string.
std::filesystem::path ParentOf(const std::filesystem::path& path) {
  const std::filesystem::path parent = path.parent_path();
  return parent.empty() ? std::filesystem::path(".") : parent;
}

}  // namespace

std::string ReadFileBytes(const std::filesystem::path& path) {
  const std::string where = path.string();
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  core::Require(std::filesystem::exists(status), where, "no such file");
  core::Require(!std::filesystem::is_directory(status), where, "is a folder, expected a file");
  std::FILE* f = std::fopen(path.c_str(), "rb");
  core::Require(f != nullptr, where, "cannot open for reading: " + ErrnoText(errno));
  // One read into a buffer of the file's size (growing in chunks costs copies and
  // page faults on the 100 MB meshes this reads); the loop still handles files that
  // change size underneath.
  std::string bytes;
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec) {
    bytes.resize(static_cast<size_t>(size));
  }
  size_t used = std::fread(bytes.data(), 1, bytes.size(), f);
  bytes.resize(used);
  char buffer[1 << 16];
  size_t got;
  while ((got = std::fread(buffer, 1, sizeof(buffer), f)) > 0) {
    bytes.append(buffer, got);
  }
  const bool failed = std::ferror(f) != 0;
  const int err = errno;
  std::fclose(f);
  core::Require(!failed, where, "read error: " + ErrnoText(err));
  return bytes;
}

void RequireParentFolder(const std::filesystem::path& path) {
  const std::filesystem::path parent = ParentOf(path);
  std::error_code ec;
  const auto status = std::filesystem::status(parent, ec);
  core::Require(std::filesystem::exists(status), path.string(),
                "cannot write: folder " + parent.string() + " does not exist");
  core::Require(std::filesystem::is_directory(status), path.string(),
                "cannot write: " + parent.string() + " is not a folder");
}

std::filesystem::path TempSiblingPath(const std::filesystem::path& path) {
  static std::atomic<uint64_t> counter{0};
  std::filesystem::path tmp = path;
  tmp += ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
  return tmp;
}

int RemoveStaleTempFiles(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  int removed = 0;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(dir, ec); !ec && it != fs::end(it);
       it.increment(ec)) {
    const std::string name = it->path().filename().string();
    // "<name>.tmp-<pid>-<n>"
    const auto at = name.rfind(".tmp-");
    if (at == std::string::npos) continue;
    const std::string rest = name.substr(at + 5);
    const auto dash = rest.find('-');
    if (dash == std::string::npos || dash == 0 || dash + 1 == rest.size() ||
        rest.find_first_not_of("0123456789-") != std::string::npos) {
      continue;
    }
    const long pid = std::stol(rest.substr(0, dash));
    const bool alive = pid == long(::getpid()) || ::kill(pid_t(pid), 0) == 0 || errno == EPERM;
    if (alive) continue;
    std::error_code rm;
    if (fs::remove(it->path(), rm)) ++removed;
  }
  return removed;
}

void CommitTempFile(const std::filesystem::path& tmp, const std::filesystem::path& path) {
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    std::remove(tmp.c_str());
    throw core::StorageError(path.string(),
                             "cannot write (rename of the finished temporary "
                             "file failed): " +
                                 ErrnoText(err));
  }
}

void WriteFileAtomically(const std::filesystem::path& path, std::string_view bytes) {
  RequireParentFolder(path);
  const std::filesystem::path tmp = TempSiblingPath(path);
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (f == nullptr) {
    throw core::StorageError(path.string(), "cannot write into folder " + ParentOf(path).string() +
                                                ": " + ErrnoText(errno));
  }
  const bool wrote = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
  const int write_err = errno;
  const bool closed = std::fclose(f) == 0;
  const int close_err = errno;
  if (!wrote || !closed) {
    std::remove(tmp.c_str());
    throw core::StorageError(path.string(),
                             "write failed: " + ErrnoText(!wrote ? write_err : close_err));
  }
  CommitTempFile(tmp, path);
}

}  // namespace dome::io
