#include "stereo/take_stereo.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <opencv2/imgcodecs.hpp>

#include "core/error.h"
#include "io/depth_tiff.h"
#include "io/file_util.h"
#include "io/image_io.h"

namespace dome::stereo {
namespace fs = std::filesystem;

void TakeStereoOptions::Check() const {
  stereo.Check();
  cluster.Check();
}

namespace {

cv::Mat ReadFrame(const fs::path& path) {
  // Keep alpha when present: it marks valid pixels.
  cv::Mat image = io::ReadImage(path, io::ImageMode::kUnchanged);
  if (image.depth() != CV_8U ||
      (image.channels() != 1 && image.channels() != 3 && image.channels() != 4)) {
    throw core::InputError(path.string(), "must be an 8-bit gray, BGR or BGRA image");
  }
  return image;
}

std::string Suffix(size_t k, int window_px) {
  return k == 0 ? std::string() : "-w" + std::to_string(window_px);
}

}  // namespace

StereoInput LoadStereoInput(const take::Take& take, const std::string& instant,
                            const std::string& camera_id, const ClusterOptions& cluster) {
  const std::vector<int> nbs = SelectCluster(take.rig, camera_id, cluster);
  StereoInput input;
  const int ref = take.rig.Find(camera_id);
  input.reference.camera = take.rig.cameras[ref].model;
  input.reference.image = ReadFrame(take.FramePath(instant, camera_id));
  for (int j : nbs) {
    StereoView v;
    v.camera = take.rig.cameras[j].model;
    v.image = ReadFrame(take.FramePath(instant, v.camera.id));
    input.neighbours.push_back(std::move(v));
  }
  return input;
}

std::vector<fs::path> WriteStereoResult(const StereoResult& result, const std::string& instant,
                                        const fs::path& out_dir, bool write_previews) {
  std::vector<fs::path> written;
  for (size_t k = 0; k < result.range_images.size(); ++k) {
    const RangeImage& r = result.range_images[k];
    const std::string sfx = Suffix(k, r.window_px);
    const fs::path base = out_dir / instant;
    std::error_code ec;
    for (const char* sub : {"depth", "reliability", "preview"}) {
      fs::create_directories(base / (sub + sfx), ec);
      core::Require(!ec, (base / (sub + sfx)).string(), "cannot create folder: " + ec.message());
    }
    const fs::path depth = base / ("depth" + sfx) / (result.camera + ".tiff");
    io::WriteDepthTiff(depth, r.depth_mm);
    std::vector<uchar> bytes;
    // Uncompressed: OpenCV's default LZW costs the master more CPU than the stereo job's
    // decoding of its frames, for a file that compresses poorly anyway (noisy floats).
    cv::imencode(".tiff", r.reliability, bytes, {cv::IMWRITE_TIFF_COMPRESSION, 1});
    io::WriteFileAtomically(
        base / ("reliability" + sfx) / (result.camera + ".tiff"),
        std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
    if (write_previews) {
      io::WriteDepthPreviewPng(base / ("preview" + sfx) / (result.camera + ".png"), r.depth_mm);
    }
    written.push_back(depth);
  }
  return written;
}

std::vector<StereoResult> RunTakeStereo(const fs::path& take_dir, const std::string& camera_id,
                                        const std::string& instant, const fs::path& out_dir,
                                        const TakeStereoOptions& options) {
  options.Check();
  const take::Take take = take::OpenTake(take_dir);
  std::vector<std::string> instants = take.instants;
  if (!instant.empty()) {
    core::Require(std::find(instants.begin(), instants.end(), instant) != instants.end(),
                  "--instant", "'" + instant + "' is not an instant of " + take_dir.string());
    instants = {instant};
  }
  std::vector<std::string> cameras;
  if (!camera_id.empty()) {
    core::Require(take.rig.Find(camera_id) >= 0, "--camera",
                  "camera '" + camera_id + "' is not in the rig of " + take_dir.string());
    cameras = {camera_id};
  } else {
    for (const auto& c : take.rig.cameras) cameras.push_back(c.model.id);
  }
  std::vector<StereoResult> results;
  for (const auto& t : instants) {
    for (const auto& cam : cameras) {
      const StereoInput input = LoadStereoInput(take, t, cam, options.cluster);
      StereoResult r = ComputeDepth(input, options.stereo);
      WriteStereoResult(r, t, out_dir, options.write_previews);
      spdlog::info("{} {}", t, r.BriefReport().substr(0, r.BriefReport().size() - 1));
      results.push_back(std::move(r));
    }
  }
  return results;
}

}  // namespace dome::stereo
