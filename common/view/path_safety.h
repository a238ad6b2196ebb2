// Confining a requested file to a root folder (the viewer serves OUT, TAKE and its
// page assets and nothing else).
//
// `relative` is the part of a URL path after the route prefix, as the HTTP server
// hands it over: already percent-decoded once. It is accepted only when it is a
// plain relative path of file names: no empty, "." or ".." segment, no leading '/',
// no backslash, no ':' (drive letters), no control character and no '%' (whatever is
// still percent-encoded after one decoding was encoded twice: dome never writes file
// names with '%', so such a request can only be an attempt to slip a '..' past a
// decoder). The file must exist, be a regular file, and its canonical path (symbolic
// links resolved) must lie inside the canonical root, so a link pointing out of the
// root is refused as well.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace dome::view {

struct ResolvedPath {
  bool ok = false;
  std::filesystem::path path;  // canonical, inside the root; set when ok
  std::string why;             // what was refused and why; set when !ok
};

// Whether `relative` has the shape described above (no file-system access).
bool IsSafeRelativePath(std::string_view relative, std::string* why = nullptr);

// The regular file `root`/`relative`, checked as described above.
ResolvedPath ResolveUnder(const std::filesystem::path& root, std::string_view relative);

}  // namespace dome::view
