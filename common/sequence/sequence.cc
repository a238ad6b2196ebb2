#include "sequence/sequence.h"

#include <algorithm>
#include <cmath>
#include <system_error>

#include "core/error.h"
#include "core/json.h"
#include "io/file_util.h"
#include "mesh/gltf.h"

namespace dome::sequence {

namespace fs = std::filesystem;

double Sequence::duration_s() const {
  if (instants.empty()) return 0;
  return instants.back().start_s + 1.0 / fps;
}

void LoadOptions::Check() const {
  // 1..120: any video or VITC rate; timecode frame fields stop at 29 (take/timecode.h).
  core::Require(std::isfinite(fps) && fps >= 1 && fps <= 120, "export: fps",
                "must be 1..120 frames a second");
}

double FramesOf(const take::Timecode& t, double fps) {
  return (double(t.hours) * 3600 + double(t.minutes) * 60 + double(t.seconds)) * fps +
         double(t.frames);
}

namespace {

// OUT/report.json's volume.voxel_size_mm, 0 when there is none (dome fuse, dome mesh).
double VoxelOf(const fs::path& out) {
  const fs::path report = out / "report.json";
  std::error_code ec;
  if (!fs::is_regular_file(report, ec)) return 0;
  try {
    const core::Json j = core::Json::parse(io::ReadFileBytes(report));
    return j.at("volume").at("voxel_size_mm").get<double>();
  } catch (const std::exception& e) {
    throw core::InputError(report.string(), std::string("volume.voxel_size_mm: ") + e.what());
  }
}

}  // namespace

Sequence LoadSequence(const fs::path& out, const LoadOptions& options) {
  options.Check();
  std::error_code ec;
  core::Require(fs::is_directory(out, ec), out.string(), "is not an output folder");
  std::vector<std::pair<take::Timecode, std::string>> names;
  for (const auto& entry : fs::directory_iterator(out, ec)) {
    if (!entry.is_directory()) continue;
    const std::string name = entry.path().filename().string();
    if (auto t = take::ParseInstantName(name)) names.emplace_back(*t, name);
  }
  core::Require(!ec, out.string(), "cannot be listed: " + ec.message());
  core::Require(!names.empty(), out.string(),
                "holds no instant folder (HH-MM-SS-FF): not an output of dome run or dome mesh");
  std::sort(names.begin(), names.end());
  Sequence seq;
  seq.fps = options.fps;
  seq.voxel_mm = VoxelOf(out);
  double first = 0;
  for (const auto& [timecode, name] : names) {
    const fs::path glb = out / name / "textured.glb";
    SequenceInstant instant;
    instant.name = name;
    instant.timecode = timecode;
    try {
      core::Require(fs::is_regular_file(glb, ec), glb.string(),
                    "is missing: the instant has no textured mesh");
      instant.textured = mesh::ReadTexturedGlb(glb);
    } catch (const core::InputError& e) {
      if (!options.skip_missing) {
        throw core::InputError("instant " + name, std::string(e.what()) +
                                                      " (--skip-missing leaves it out)");
      }
      seq.skipped.push_back({name, e.what()});
      continue;
    }
    if (seq.instants.empty()) first = FramesOf(timecode, options.fps);
    instant.start_s = (FramesOf(timecode, options.fps) - first) / options.fps;
    seq.instants.push_back(std::move(instant));
  }
  core::Require(!seq.instants.empty(), out.string(),
                "has no instant with a readable textured mesh (" +
                    std::to_string(seq.skipped.size()) + " skipped)");
  return seq;
}

}  // namespace dome::sequence
