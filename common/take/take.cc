#include "take/take.h"

#include <algorithm>

#include "core/error.h"
#include "schema/rig_json.h"
#include "take/timecode.h"

namespace dome::take {

namespace fs = std::filesystem;
using core::Require;

fs::path Take::FramePath(const std::string& instant, const std::string& camera) const {
  return dir / "frames" / instant / (camera + ".png");
}

fs::path Take::TruthMeshPath(const std::string& instant) const {
  return dir / "truth" / instant / "mesh.ply";
}

fs::path Take::TruthDepthPath(const std::string& instant, const std::string& camera) const {
  return dir / "truth" / instant / "depth" / (camera + ".tiff");
}

Take OpenTake(const fs::path& dir) {
  std::error_code ec;
  Require(fs::is_directory(dir, ec), dir.string(), "not a take folder (no such directory)");
  Take take;
  take.dir = dir;
  Require(fs::is_regular_file(take.RigPath(), ec), take.RigPath().string(),
          "missing: a take needs rig.json");
  take.rig = schema::ReadRig(take.RigPath());
  const fs::path frames = dir / "frames";
  Require(fs::is_directory(frames, ec), frames.string(),
          "missing: a take needs frames/<instant>/<camera>.png");
  for (const auto& entry : fs::directory_iterator(frames)) {
    const std::string name = entry.path().filename().string();
    Require(entry.is_directory() && ParseInstantName(name).has_value(), entry.path().string(),
            "expected an instant folder named by timecode HH-MM-SS-FF");
    take.instants.push_back(name);
  }
  Require(!take.instants.empty(), frames.string(), "no instants: expected at least one folder");
  std::sort(take.instants.begin(), take.instants.end());
  return take;
}

void CreateTakeDir(const fs::path& dir, bool overwrite) {
  std::error_code ec;
  Require(overwrite || !fs::exists(dir / "rig.json", ec), (dir / "rig.json").string(),
          "already exists (pass --overwrite to replace the take)");
  fs::create_directories(dir / "frames", ec);
  Require(!ec, dir.string(), "cannot create the take folder: " + ec.message());
}

}  // namespace dome::take
