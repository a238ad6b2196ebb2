// The take folder: dome's input format.
//
//   TAKE/rig.json                          cameras (schema/rig_json.h)
//   TAKE/frames/<instant>/<camera>.png     one image per camera per instant: 8-bit
//                                          gray, BGR, or BGRA whose alpha marks valid
//                                          pixels (255) and pixels without data (0)
//   TAKE/calib/...                         optional: calibration images and targets
//   TAKE/masks/<instant>/<camera>.png      optional: given foreground masks, 8-bit, nonzero =
//                                          foreground (silhouette/take_masks.h)
//   TAKE/background/<camera>.png           optional: background plates, the empty scene, as
//                                          the frames (silhouette/take_masks.h)
//   TAKE/truth/<instant>/mesh.ply          optional synthetic ground truth: scene mesh (mm)
//   TAKE/truth/<instant>/depth/<camera>.tiff   z-depth along the optical axis,
//                                          32-bit float, mm, 0 = no surface
//   TAKE/truth/<instant>/mask/<camera>.png  optional truth foreground mask, 255 = person
//
// <instant> is the VITC timecode of the instant as HH-MM-SS-FF (take/timecode.h);
// <camera> is a camera id from rig.json. Image sizes equal the rig's width_px x height_px.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "geometry/rig.h"

namespace dome::take {

struct Take {
  std::filesystem::path dir;
  geometry::Rig rig;
  std::vector<std::string> instants;  // sorted, i.e. in time order

  std::filesystem::path RigPath() const { return dir / "rig.json"; }
  std::filesystem::path FramePath(const std::string& instant, const std::string& camera) const;
  std::filesystem::path TruthMeshPath(const std::string& instant) const;
  std::filesystem::path TruthDepthPath(const std::string& instant, const std::string& camera) const;
};

// Reads rig.json and lists the instants under frames/. Throws core::InputError when
// the folder, the rig or frames/ is missing or malformed. It does not open images;
// ValidateTake (take/validate.h) checks everything.
Take OpenTake(const std::filesystem::path& dir);

// Creates TAKE/ and TAKE/frames/ (an empty take to fill). Throws core::InputError
// naming the folder when it cannot be created or already holds a rig.json and
// `overwrite` is false.
void CreateTakeDir(const std::filesystem::path& dir, bool overwrite);

// Writes a new take so that a failure part way leaves nothing half written: files go
// to a staging folder beside `dir` (".<name>.partial-<pid>", the same file system, so
// the final move is one rename) and Commit() moves it into place. Without Commit()
// the destructor removes the staging folder, and an existing take at `dir` is left
// as it was. The constructor throws core::InputError naming `dir` when it already
// holds a take and `overwrite` is false, or holds something that is not a take.
class TakeWriter {
 public:
  TakeWriter(std::filesystem::path dir, bool overwrite);
  ~TakeWriter();
  TakeWriter(const TakeWriter&) = delete;
  TakeWriter& operator=(const TakeWriter&) = delete;

  // The final folder, for messages; files are written under Staged() until Commit().
  const std::filesystem::path& dir() const { return dir_; }
  // `relative` under the staging folder, its parent folders created.
  std::filesystem::path Staged(const std::filesystem::path& relative) const;
  // frames/<instant>/<camera>.png under the staging folder, its folder created.
  std::filesystem::path FramePath(const std::string& instant, const std::string& camera) const;

  // Writes rig.json, moves the take into place (replacing the old one when allowed)
  // and returns it. A take with no frames written is a rig-only take: empty
  // `instants`, and OpenTake refuses it until frames are added.
  Take Commit(const geometry::Rig& rig);

 private:
  std::filesystem::path dir_;
  std::filesystem::path staging_;
  bool overwrite_ = false;
  bool committed_ = false;
};

}  // namespace dome::take
