#include "take/import_frames.h"

#include <algorithm>
#include <cctype>

#include "core/error.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "take/timecode.h"

namespace dome::take::internal {

namespace fs = std::filesystem;
using core::Require;

std::string InstantOfFrame(long frame, int fps, const std::string& where) {
  DOME_CHECK(fps >= 1 && fps <= 30 && frame >= 0, "frame and rate in range");
  Timecode tc;
  tc.frames = int(frame % fps);
  tc.seconds = int(frame / fps % 60);
  tc.minutes = int(frame / fps / 60 % 60);
  tc.hours = int(frame / fps / 3600);
  Require(tc.hours < 24, where,
          "frame " + std::to_string(frame) + " is beyond 24 hours at " + std::to_string(fps) +
              " frames a second");
  return tc.FolderName();
}

void CopyImage(const fs::path& from, const fs::path& to, const geometry::TsaiCamera& camera) {
  // Decoded in every case, so a corrupt or wrongly sized source fails here, named.
  const cv::Mat image = io::ReadImage(from, io::ImageMode::kUnchanged);
  Require(image.cols == camera.width_px && image.rows == camera.height_px, from.string(),
          "is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) + ", but camera '" +
              camera.id + "' is calibrated for " + std::to_string(camera.width_px) + "x" +
              std::to_string(camera.height_px));
  if (from.extension() == ".png" || from.extension() == ".PNG") {
    io::WriteFileAtomically(to, io::ReadFileBytes(from));
  } else {
    io::WriteImage(to, image);
  }
}

CameraFrames NumberedFrames(const fs::path& folder, const std::string& prefix) {
  std::error_code ec;
  Require(fs::is_directory(folder, ec), folder.string(), "missing: expected a folder of frames");
  CameraFrames frames;
  for (const auto& e : fs::directory_iterator(folder)) {
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (ext != ".png" && ext != ".jpg" && ext != ".jpeg" && ext != ".tif" && ext != ".tiff" &&
        ext != ".bmp") {
      continue;
    }
    const std::string stem = e.path().stem().string();
    if (stem.compare(0, prefix.size(), prefix) != 0) continue;
    size_t end = stem.size();
    while (end > prefix.size() && !std::isdigit(static_cast<unsigned char>(stem[end - 1]))) --end;
    size_t begin = end;
    while (begin > prefix.size() && std::isdigit(static_cast<unsigned char>(stem[begin - 1]))) {
      --begin;
    }
    if (begin == end || end - begin > 9) continue;  // no frame number
    frames.emplace_back(
        InstantOfFrame(std::stol(stem.substr(begin, end - begin)), 30, e.path().string()),
        e.path());
  }
  Require(!frames.empty(), folder.string(),
          "holds no frames named " + prefix + "<number>.png|jpg (a camera without images)");
  std::sort(frames.begin(), frames.end());
  for (size_t i = 1; i < frames.size(); ++i) {
    Require(frames[i].first != frames[i - 1].first, frames[i].second.string(),
            "has the same frame number as " + frames[i - 1].second.string());
  }
  return frames;
}

void RequireSameInstants(const std::vector<CameraFrames>& frames,
                         const std::vector<fs::path>& folders) {
  const auto instants = [](const CameraFrames& f) {
    std::vector<std::string> out;
    for (const auto& [instant, file] : f) out.push_back(instant);
    return out;
  };
  for (size_t c = 1; c < frames.size(); ++c) {
    Require(instants(frames[c]) == instants(frames[0]), folders[c].string(),
            "does not hold the same frames as " + folders[0].string() + " (" +
                std::to_string(frames[c].size()) + " against " + std::to_string(frames[0].size()) +
                ")");
  }
}

Take WriteFrames(const geometry::Rig& rig, const std::vector<CameraFrames>& frames,
                 const fs::path& out, bool overwrite) {
  DOME_CHECK(frames.empty() || frames.size() == rig.cameras.size(), "frames of every camera");
  TakeWriter writer(out, overwrite);
  for (size_t c = 0; c < frames.size(); ++c) {
    const geometry::TsaiCamera& m = rig.cameras[c].model;
    for (const auto& [instant, file] : frames[c])
      CopyImage(file, writer.FramePath(instant, m.id), m);
  }
  return writer.Commit(rig);
}

}  // namespace dome::take::internal
