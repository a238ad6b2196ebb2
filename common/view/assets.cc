#include "view/assets.h"

#include <cstdlib>
#include <system_error>

#include "core/error.h"

namespace dome::view {

namespace fs = std::filesystem;

fs::path FindViewerAssets() {
  fs::path dir;
  if (const char* env = std::getenv("DOME_VIEWER_DIR"); env != nullptr && *env != '\0') {
    dir = env;
  } else {
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    core::Require(!ec, "/proc/self/exe", "cannot find the running executable");
    dir = exe.parent_path().parent_path() / "share" / "dome" / "viewer";
  }
  for (const char* file : kAssetFiles) {
    std::error_code ec;
    core::Require(fs::is_regular_file(dir / file, ec), (dir / file).string(),
                  "viewer page file missing (build the 'viewer_assets' target, or set "
                  "DOME_VIEWER_DIR to a folder holding the page)");
  }
  return dir;
}

}  // namespace dome::view
