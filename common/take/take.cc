#include "take/take.h"

#include <unistd.h>

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

TakeWriter::TakeWriter(fs::path dir, bool overwrite) : dir_(std::move(dir)), overwrite_(overwrite) {
  if (dir_.filename().empty()) dir_ = dir_.parent_path();  // "out/" -> "out"
  std::error_code ec;
  if (fs::exists(dir_, ec)) {
    Require(fs::is_directory(dir_, ec), dir_.string(), "exists and is not a folder");
    const bool is_take = fs::exists(dir_ / "rig.json", ec);
    Require(overwrite_ || !is_take, (dir_ / "rig.json").string(),
            "already exists (pass --overwrite to replace the take)");
    // Replacing a folder that is not a take could delete a user's files.
    Require(is_take || fs::is_empty(dir_, ec), dir_.string(),
            "is not empty and holds no take (rig.json): give a new or empty folder");
  }
  const fs::path parent = fs::absolute(dir_, ec).parent_path();
  staging_ = parent / ("." + dir_.filename().string() + ".partial-" + std::to_string(::getpid()));
  fs::remove_all(staging_, ec);  // left by an earlier process of the same pid
  fs::create_directories(staging_ / "frames", ec);
  Require(!ec, staging_.string(), "cannot create the take's staging folder: " + ec.message());
}

TakeWriter::~TakeWriter() {
  if (committed_) return;
  std::error_code ec;
  fs::remove_all(staging_, ec);
}

fs::path TakeWriter::Staged(const fs::path& relative) const {
  const fs::path path = staging_ / relative;
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  Require(!ec, path.parent_path().string(), "cannot create folder: " + ec.message());
  return path;
}

fs::path TakeWriter::FramePath(const std::string& instant, const std::string& camera) const {
  return Staged(fs::path("frames") / instant / (camera + ".png"));
}

Take TakeWriter::Commit(const geometry::Rig& rig) {
  DOME_CHECK(!committed_, "a take is committed once");
  schema::WriteRig(rig, staging_ / "rig.json");
  std::error_code ec;
  fs::path old;
  if (fs::exists(dir_, ec) && !fs::is_empty(dir_, ec)) {
    // Move the old take aside first: the new one then lands by one rename, and a
    // failure in between leaves the old take in a named folder, not half deleted.
    old = staging_;
    old += ".old";
    fs::remove_all(old, ec);
    fs::rename(dir_, old, ec);
    Require(!ec, dir_.string(), "cannot move the old take aside: " + ec.message());
  } else if (fs::exists(dir_, ec)) {
    fs::remove(dir_, ec);  // an empty folder the user made for the take
  }
  fs::create_directories(dir_.parent_path().empty() ? fs::path(".") : dir_.parent_path(), ec);
  fs::rename(staging_, dir_, ec);
  Require(!ec, dir_.string(),
          "cannot move the new take into place: " + ec.message() +
              (old.empty() ? std::string() : "; the old take is in " + old.string()));
  committed_ = true;
  if (!old.empty()) fs::remove_all(old, ec);
  Take take;
  take.dir = dir_;
  take.rig = rig;
  for (const auto& entry : fs::directory_iterator(dir_ / "frames")) {
    take.instants.push_back(entry.path().filename().string());
  }
  std::sort(take.instants.begin(), take.instants.end());
  return take;
}

}  // namespace dome::take
