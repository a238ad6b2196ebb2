#include "view/path_safety.h"

#include <system_error>

namespace dome::view {

namespace fs = std::filesystem;

bool IsSafeRelativePath(std::string_view relative, std::string* why) {
  auto refuse = [&](const std::string& reason) {
    if (why != nullptr) *why = reason;
    return false;
  };
  if (relative.empty()) return refuse("empty path");
  if (relative.front() == '/') return refuse("absolute path");
  for (const char c : relative) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7f) return refuse("control character in path");
    if (c == '\\') return refuse("backslash in path");
    if (c == ':') return refuse("':' in path");
    if (c == '%') return refuse("percent-encoded characters left after decoding");
  }
  size_t start = 0;
  while (start <= relative.size()) {
    size_t end = relative.find('/', start);
    if (end == std::string_view::npos) end = relative.size();
    const std::string_view segment = relative.substr(start, end - start);
    if (segment.empty()) return refuse("empty path segment");
    if (segment == "." || segment == "..") return refuse("'" + std::string(segment) + "' segment");
    start = end + 1;
  }
  return true;
}

ResolvedPath ResolveUnder(const fs::path& root, std::string_view relative) {
  ResolvedPath r;
  if (!IsSafeRelativePath(relative, &r.why)) return r;
  std::error_code ec;
  const fs::path canonical_root = fs::canonical(root, ec);
  if (ec) {
    r.why = "root folder " + root.string() + " is not readable";
    return r;
  }
  const fs::path target = fs::canonical(canonical_root / fs::path(std::string(relative)), ec);
  if (ec) {
    r.why = "no such file";
    return r;
  }
  // Component-wise prefix test: "/a/bc" is not inside "/a/b".
  auto t = target.begin();
  for (auto it = canonical_root.begin(); it != canonical_root.end(); ++it, ++t) {
    if (t == target.end() || *t != *it) {
      r.why = "resolves outside the served folder";
      return r;
    }
  }
  if (!fs::is_regular_file(target, ec)) {
    r.why = "not a regular file";
    return r;
  }
  r.ok = true;
  r.path = target;
  return r;
}

}  // namespace dome::view
