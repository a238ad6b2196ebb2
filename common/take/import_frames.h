// What the importers (take/import.h) share: copying a source image into a take and
// turning numbered source frames into instants. Internal to the take library.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "geometry/rig.h"
#include "take/take.h"

namespace dome::take::internal {

// The instant (folder name HH-MM-SS-FF) of frame number `frame` of a recording at
// `fps` frames a second (1..30), counting from 00:00:00:00. Throws core::InputError
// naming `where` beyond 24 hours.
std::string InstantOfFrame(long frame, int fps, const std::string& where);

// Copies an image into the take as PNG: byte copy for PNG sources, re-encoding
// (lossless, 8-bit, channels kept) for anything else. Throws core::InputError naming
// `from` when it cannot be decoded or is not of `camera`'s calibrated size.
void CopyImage(const std::filesystem::path& from, const std::filesystem::path& to,
               const geometry::TsaiCamera& camera);

// One camera's frames: (instant, file), sorted by instant.
using CameraFrames = std::vector<std::pair<std::string, std::filesystem::path>>;

// The image files in `folder` named <prefix><number>.<ext> (ext png, jpg, jpeg, tif,
// tiff, bmp, any case; <number> the last run of digits before the extension), each
// numbered frame an instant at 30 frames a second (frame 4500 -> 00-02-30-00). Throws
// core::InputError naming the folder when it holds none, or two files of one number.
CameraFrames NumberedFrames(const std::filesystem::path& folder, const std::string& prefix);

// Throws core::InputError naming camera c's folder when its instants differ from
// camera 0's. `folders[c]` names camera c's source in the message.
void RequireSameInstants(const std::vector<CameraFrames>& frames,
                         const std::vector<std::filesystem::path>& folders);

// Writes every camera's frames (frames[c] for rig camera c) and the rig through a
// TakeWriter and returns the take.
Take WriteFrames(const geometry::Rig& rig, const std::vector<CameraFrames>& frames,
                 const std::filesystem::path& out, bool overwrite);

}  // namespace dome::take::internal
