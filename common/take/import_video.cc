// ImportVideo (take/import.h): one video per camera, streamed into a take.
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "core/error.h"
#include "io/image_io.h"
#include "take/import.h"
#include "take/import_frames.h"
#include "take/timecode.h"
#include "video/video.h"

namespace dome::take {
namespace {

namespace fs = std::filesystem;
using core::Require;

// A timeline frame given as a whole number or a timecode HH:MM:SS:FF (';' before the
// frames for drop-frame, '-' as in folder names) at `fps`.
long ParseFrame(const std::string& text, int fps, const std::string& where) {
  if (!text.empty() && std::all_of(text.begin(), text.end(), ::isdigit) && text.size() <= 9) {
    return std::stol(text);
  }
  std::string name = text;
  std::replace(name.begin(), name.end(), ':', '-');
  std::replace(name.begin(), name.end(), ';', '-');
  const std::optional<Timecode> tc = ParseInstantName(name);
  Require(tc.has_value(), where,
          "expected a frame number or a timecode HH:MM:SS:FF, got '" + text + "'");
  Require(tc->frames < fps, where,
          "timecode '" + text + "' has frame " + std::to_string(tc->frames) + " at " +
              std::to_string(fps) + " frames a second");
  return ((tc->hours * 60L + tc->minutes) * 60 + tc->seconds) * fps + tc->frames;
}

// The one file in `dir` whose stem is the camera's id.
fs::path VideoOf(const fs::path& dir, const std::string& id) {
  fs::path found;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file() || e.path().stem().string() != id) continue;
    Require(found.empty(), e.path().string(),
            "a second video for camera '" + id + "' (besides " + found.string() + ")");
    found = e.path();
  }
  Require(!found.empty(), (dir / (id + ".*")).string(),
          "missing: camera '" + id + "' has no video");
  return found;
}

struct Source {
  fs::path path;
  long offset = 0;  // timeline frame of video frame 0
  long count = -1;  // frames the container reports; -1 when it does not say
  double fps = 0;
};

Source Probe(const fs::path& path, const geometry::TsaiCamera& camera) {
  const std::unique_ptr<video::Source> clip = video::OpenFile(path.string());
  Source s;
  s.path = path;
  s.fps = clip->fps();
  const double count = clip->frame_count();
  if (count > 0) s.count = std::lround(count);
  const int w = clip->size().width;
  const int h = clip->size().height;
  Require(w == camera.width_px && h == camera.height_px, path.string(),
          "frames are " + std::to_string(w) + "x" + std::to_string(h) + ", but camera '" +
              camera.id + "' is calibrated for " + std::to_string(camera.width_px) + "x" +
              std::to_string(camera.height_px));
  return s;
}

}  // namespace

void VideoImportOptions::Check() const {
  Require(range.empty() || range.size() == 2, "--range", "expected FIRST LAST");
  Require(every >= 1, "--every", "must be at least 1, got " + std::to_string(every));
  Require(instants.empty() || (range.empty() && every == 1), "--instants",
          "cannot be combined with --range or --every");
  Require(fps >= 0 && fps <= 30, "--fps",
          "must be 1..30 (instants are named by timecode), got " + std::to_string(fps));
  for (const auto& [id, tc] : start_timecodes) {
    Require(!offset_frames.count(id), "--start " + id, "camera has an --offset too");
  }
}

Take ImportVideo(const geometry::Rig& rig, const fs::path& video_dir, const fs::path& out,
                 const VideoImportOptions& video, const ImportOptions& options) {
  options.Check();
  video.Check();
  std::error_code ec;
  Require(fs::is_directory(video_dir, ec), video_dir.string(),
          "not a folder of videos (<camera>.<ext>, one per camera)");
  Require(!rig.cameras.empty(), "rig", "has no cameras");
  const auto known = [&](const std::string& id) {
    return std::any_of(rig.cameras.begin(), rig.cameras.end(),
                       [&](const auto& rc) { return rc.model.id == id; });
  };
  for (const auto& [id, n] : video.offset_frames) {
    Require(known(id), "--offset " + id, "no such camera in the rig");
  }
  for (const auto& [id, tc] : video.start_timecodes) {
    Require(known(id), "--start " + id, "no such camera in the rig");
  }

  // Everything is probed before anything is written.
  std::vector<Source> sources;
  for (const auto& rc : rig.cameras) {
    sources.push_back(Probe(VideoOf(video_dir, rc.model.id), rc.model));
  }
  int fps = video.fps;
  if (fps == 0) {
    fps = int(std::lround(sources[0].fps));
    Require(fps >= 1 && fps <= 30, sources[0].path.string(),
            "has " + std::to_string(sources[0].fps) +
                " frames a second; give --fps 1..30 to name its frames by timecode");
    for (const Source& s : sources) {
      Require(std::abs(s.fps - sources[0].fps) <= 0.005 * sources[0].fps, s.path.string(),
              "has " + std::to_string(s.fps) + " frames a second, " + sources[0].path.string() +
                  " " + std::to_string(sources[0].fps) + "; give --fps to set the timeline's");
    }
  }
  for (size_t c = 0; c < sources.size(); ++c) {
    const std::string& id = rig.cameras[c].model.id;
    if (const auto it = video.offset_frames.find(id); it != video.offset_frames.end()) {
      sources[c].offset = it->second;
    } else if (const auto tc = video.start_timecodes.find(id); tc != video.start_timecodes.end()) {
      sources[c].offset = ParseFrame(tc->second, fps, "--start " + id);
    }
  }

  // The timeline frames wanted.
  long first = 0, last = -1;  // the span every camera covers, when the containers say
  bool counted = true;
  for (const Source& s : sources) {
    first = std::max(first, s.offset);
    counted = counted && s.count >= 0;
  }
  if (counted) {
    last = std::numeric_limits<long>::max();
    for (const Source& s : sources) last = std::min(last, s.offset + s.count - 1);
  }
  std::vector<long> wanted;
  if (!video.instants.empty()) {
    for (const auto& text : video.instants) wanted.push_back(ParseFrame(text, fps, "--instants"));
    std::sort(wanted.begin(), wanted.end());
    wanted.erase(std::unique(wanted.begin(), wanted.end()), wanted.end());
  } else {
    if (!video.range.empty()) {
      first = ParseFrame(video.range[0], fps, "--range");
      last = ParseFrame(video.range[1], fps, "--range");
      Require(first <= last, "--range", "FIRST is after LAST");
    }
    Require(last >= first, video_dir.string(),
            counted ? "the videos share no frame (offsets put them apart)"
                    : "a container does not say how many frames it holds: give --range");
    for (long g = first; g <= last; g += video.every) wanted.push_back(g);
  }
  // Every camera must hold every wanted frame.
  for (const Source& s : sources) {
    const long need_first = wanted.front() - s.offset;
    const long need_last = wanted.back() - s.offset;
    Require(need_first >= 0, s.path.string(),
            "starts at timeline frame " + std::to_string(s.offset) + ", after frame " +
                std::to_string(wanted.front()) + " that is asked for");
    Require(s.count < 0 || need_last < s.count, s.path.string(),
            "holds " + std::to_string(s.count) + " frames (timeline " + std::to_string(s.offset) +
                ".." + std::to_string(s.offset + s.count - 1) +
                "), shorter than the frames asked for (up to " + std::to_string(wanted.back()) +
                ")");
  }
  std::vector<std::string> names;
  for (long g : wanted) names.push_back(internal::InstantOfFrame(g, fps, "--range"));

  // One pass per camera, in frame order: decode, write the frame if wanted, drop it.
  TakeWriter writer(out, options.overwrite);
  for (size_t c = 0; c < sources.size(); ++c) {
    const Source& s = sources[c];
    const geometry::TsaiCamera& camera = rig.cameras[c].model;
    const std::unique_ptr<video::Source> capture = video::OpenFile(s.path.string());
    size_t next = 0;
    cv::Mat frame;
    for (long i = 0; next < wanted.size(); ++i) {
      const bool take_it = i + s.offset == wanted[next];
      const bool ok = take_it ? capture->Read(&frame) : capture->Skip();
      Require(ok, s.path.string(),
              "ended or failed to decode at frame " + std::to_string(i) + " (timeline " +
                  std::to_string(i + s.offset) + "), before frame " +
                  std::to_string(wanted.back() - s.offset) + " that is asked for");
      if (!take_it) continue;
      Require(frame.cols == camera.width_px && frame.rows == camera.height_px, s.path.string(),
              "frame " + std::to_string(i) + " is " + std::to_string(frame.cols) + "x" +
                  std::to_string(frame.rows) + ", not the calibrated size");
      io::WriteImage(writer.FramePath(names[next], camera.id), frame);
      ++next;
    }
  }
  return writer.Commit(rig);
}

}  // namespace dome::take
