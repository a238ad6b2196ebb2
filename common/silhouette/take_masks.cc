#include "silhouette/take_masks.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "io/file_util.h"
#include "io/image_io.h"

namespace dome::silhouette {

namespace fs = std::filesystem;
using core::Require;

namespace {

std::string SizeText(cv::Size s) {
  return std::to_string(s.width) + "x" + std::to_string(s.height);
}

cv::Size CameraSize(const take::Take& take, const std::string& camera) {
  const int index = take.rig.Find(camera);
  Require(index >= 0, take.RigPath().string(), "no camera '" + camera + "'");
  const auto& model = take.rig.cameras[index].model;
  return {model.width_px, model.height_px};
}

void RequireSize(const std::string& path, cv::Size got, cv::Size expected, const std::string& camera) {
  Require(got == expected, path,
          "image is " + SizeText(got) + ", rig.json says camera '" + camera + "' is " +
              SizeText(expected));
}

// `image` with `channels` channels (1 gray, 3 BGR).
cv::Mat ToChannels(const cv::Mat& image, int channels) {
  if (image.channels() == channels) return image;
  cv::Mat out;
  cv::cvtColor(image, out, channels == 1 ? cv::COLOR_BGR2GRAY : cv::COLOR_GRAY2BGR);
  return out;
}

// A given mask as 255 / 0, checked for depth and size.
cv::Mat ReadMaskFile(const fs::path& path, cv::Size size, const std::string& camera) {
  return MaskImage(io::ReadImage(path, io::ImageMode::kUnchanged), size, camera, path.string());
}

}  // namespace

const char* MaskSourceName(MaskSource source) {
  switch (source) {
    case MaskSource::kGiven:
      return "given";
    case MaskSource::kPlate:
      return "plate";
    case MaskSource::kMedian:
      return "median";
  }
  return "?";
}

void MaskOptions::Check() const {
  foreground.Check();
  cleanup.Check();
  Require(median_max_instants >= kMinMedianInstants, "MaskOptions: median_max_instants",
          "expected at least " + std::to_string(kMinMedianInstants) + ", got " +
              std::to_string(median_max_instants));
}

std::vector<std::string> MedianInstants(const std::vector<std::string>& instants, int max_count) {
  const int n = static_cast<int>(instants.size());
  if (n <= max_count) return instants;
  std::vector<std::string> out;
  for (int i = 0; i < max_count; ++i) {
    const int k = static_cast<int>(std::lround(static_cast<double>(i) * (n - 1) / (max_count - 1)));
    out.push_back(instants[k]);
  }
  return out;
}

cv::Mat MaskImage(const cv::Mat& raw, cv::Size size, const std::string& camera,
                  const std::string& where) {
  Require(raw.depth() == CV_8U, where,
          "expected an 8-bit mask (0 = background, nonzero = foreground), got depth code " +
              std::to_string(raw.depth()));
  RequireSize(where, raw.size(), size, camera);
  cv::Mat first;
  cv::extractChannel(raw, first, 0);
  return first != 0;  // 255 / 0
}

Frame ReadFrame(const fs::path& path, cv::Size size, const std::string& camera) {
  return SplitFrame(io::ReadImage(path, io::ImageMode::kUnchanged), size, camera, path.string());
}

Frame SplitFrame(const cv::Mat& raw, cv::Size size, const std::string& camera,
                 const std::string& where) {
  Require(
      raw.depth() == CV_8U && (raw.channels() == 1 || raw.channels() == 3 || raw.channels() == 4),
      where,
      "expected an 8-bit gray, BGR or BGRA image, got " + std::to_string(raw.channels()) +
          " channel(s) of depth code " + std::to_string(raw.depth()));
  RequireSize(where, raw.size(), size, camera);
  Frame frame;
  if (raw.channels() == 4) {
    cv::cvtColor(raw, frame.colour, cv::COLOR_BGRA2BGR);
    cv::Mat alpha;
    cv::extractChannel(raw, alpha, 3);
    frame.valid = alpha != 0;
  } else {
    frame.colour = raw;
  }
  return frame;
}

fs::path TakeMasks::GivenMaskPath(const std::string& instant, const std::string& camera) const {
  return take_.dir / "masks" / instant / (camera + ".png");
}

fs::path TakeMasks::PlatePath(const std::string& camera) const {
  return take_.dir / "background" / (camera + ".png");
}

std::vector<fs::path> TakeMasks::InputPaths(const std::string& instant,
                                            const std::string& camera) const {
  switch (Source(camera)) {
    case MaskSource::kGiven:
      return {GivenMaskPath(instant, camera)};
    case MaskSource::kPlate:
      return {take_.FramePath(instant, camera), PlatePath(camera)};
    case MaskSource::kMedian: {
      std::vector<fs::path> paths = {take_.FramePath(instant, camera)};
      for (const auto& m : MedianInstants(take_.instants, options_.median_max_instants))
        paths.push_back(take_.FramePath(m, camera));
      return paths;
    }
  }
  return {};
}

std::map<std::string, MaskSource> DecideMaskSources(const take::Take& take) {
  std::error_code ec;
  std::map<std::string, MaskSource> sources;
  std::vector<std::string> median_cameras;
  for (const auto& rc : take.rig.cameras) {
    const std::string& id = rc.model.id;
    bool any_given = false;
    for (const auto& instant : take.instants)
      any_given = any_given || fs::exists(take.dir / "masks" / instant / (id + ".png"), ec);
    if (any_given) {
      sources[id] = MaskSource::kGiven;
    } else if (fs::exists(take.dir / "background" / (id + ".png"), ec)) {
      sources[id] = MaskSource::kPlate;
    } else {
      sources[id] = MaskSource::kMedian;
      median_cameras.push_back(id);
    }
  }
  if (!median_cameras.empty()) {
    const int n = static_cast<int>(take.instants.size());
    Require(n >= MaskOptions::kMinMedianInstants, (take.dir / "frames").string(),
            std::to_string(n) + " instant(s): a median background needs at least " +
                std::to_string(MaskOptions::kMinMedianInstants) +
                " (the person must be elsewhere in most of them); camera '" +
                median_cameras.front() + "' has neither background/" + median_cameras.front() +
                ".png nor masks/<instant>/" + median_cameras.front() + ".png");
  }
  return sources;
}

TakeMasks::TakeMasks(take::Take take, const MaskOptions& options)
    : take_(std::move(take)), options_(options) {
  options_.Check();
  sources_ = DecideMaskSources(take_);
  std::error_code ec;
  for (const auto& rc : take_.rig.cameras) {
    const std::string& id = rc.model.id;
    const cv::Size size(rc.model.width_px, rc.model.height_px);
    backgrounds_[id];  // every camera's slot exists, so Mask() never inserts
    consensus_[id];
    if (sources_.at(id) == MaskSource::kGiven) {
      // Given masks are all or nothing per camera: half given, half derived would mix
      // two definitions of the silhouette in one camera.
      for (const auto& instant : take_.instants) {
        const fs::path path = GivenMaskPath(instant, id);
        Require(fs::exists(path, ec), path.string(),
                "missing: camera '" + id +
                    "' has given masks for other instants, so every "
                    "instant needs one");
        ReadMaskFile(path, size, id);  // kind and size, before any work
      }
    } else if (sources_.at(id) == MaskSource::kPlate) {
      ReadFrame(PlatePath(id), size, id);  // kind and size, before any work
    }
  }
}

MaskSource TakeMasks::Source(const std::string& camera) const {
  const auto it = sources_.find(camera);
  Require(it != sources_.end(), take_.RigPath().string(), "no camera '" + camera + "'");
  return it->second;
}

const cv::Mat& TakeMasks::Background(const std::string& camera, int channels) {
  cv::Mat& slot = backgrounds_.at(camera);
  if (slot.empty()) {
    const cv::Size size = CameraSize(take_, camera);
    if (Source(camera) == MaskSource::kPlate) {
      slot = ReadFrame(PlatePath(camera), size, camera).colour;
    } else {
      std::vector<cv::Mat> images;
      for (const auto& instant : MedianInstants(take_.instants, options_.median_max_instants)) {
        const fs::path path = take_.FramePath(instant, camera);
        images.push_back(SplitFrame(ReadRaw(path), size, camera, path.string()).colour);
      }
      slot = MedianBackground(images, channels, &consensus_.at(camera));
    }
  }
  return slot;
}

cv::Mat TakeMasks::Mask(const std::string& instant, const std::string& camera, MaskInfo* info) {
  const cv::Size size = CameraSize(take_, camera);
  const MaskSource source = Source(camera);
  MaskInfo local;
  local.source = source;
  cv::Mat mask;
  if (source == MaskSource::kGiven) {
    mask = ReadMaskFile(GivenMaskPath(instant, camera), size, camera);
  } else {
    const fs::path path = take_.FramePath(instant, camera);
    const cv::Mat image = ReadRaw(path);
    const Frame frame = SplitFrame(image, size, camera, path.string());  // checked first
    if (frame_seen_) frame_seen_(path, image);
    mask = MaskAgainst(frame, Background(camera, frame.colour.channels()), source, options_,
                       &local);
  }
  local.fraction = static_cast<double>(cv::countNonZero(mask)) / (size.width * size.height);
  if (info != nullptr) *info = local;
  return mask;
}

cv::Mat TakeMasks::ReadRaw(const fs::path& path) const {
  return frame_reader_ ? frame_reader_(path) : io::ReadImage(path, io::ImageMode::kUnchanged);
}

ConsensusStats TakeMasks::BackgroundConsensus(const std::string& camera) const {
  const auto it = consensus_.find(camera);
  Require(it != consensus_.end(), take_.RigPath().string(), "no camera '" + camera + "'");
  return it->second;
}

cv::Mat MedianBackground(const std::vector<cv::Mat>& colours, int channels, ConsensusStats* stats) {
  std::vector<cv::Mat> images;
  for (const auto& c : colours) images.push_back(ToChannels(c, channels));
  return ConsensusBackground(images, ConsensusOptions{}, stats);
}

cv::Mat MaskAgainst(const Frame& frame, const cv::Mat& background, MaskSource source,
                    const MaskOptions& options, MaskInfo* info) {
  // A gray plate for colour frames (or the reverse): both in the fewer channels.
  const int channels = std::min(frame.colour.channels(), background.channels());
  MaskInfo local;
  local.source = source;
  const cv::Mat raw = ClassifyForeground(
      ToChannels(frame.colour, channels), ToChannels(background, channels), frame.valid,
      options.foreground, source == MaskSource::kMedian, &local.stats);
  cv::Mat mask = CleanMask(raw, frame.valid, options.cleanup);
  local.fraction = static_cast<double>(cv::countNonZero(mask)) / double(mask.total());
  if (info != nullptr) *info = local;
  return mask;
}

cv::Mat MaskPreview(const cv::Mat& image, const cv::Mat& mask) {
  DOME_CHECK(image.size() == mask.size(), "MaskPreview: a mask of the image's size");
  cv::Mat bgr = ToChannels(image, 3).clone();
  cv::Mat dim = bgr / 3;
  dim.copyTo(bgr, mask == 0);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask.clone(), contours, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
  const int thickness = std::max(1, static_cast<int>(std::lround(image.cols / 640.0)));
  cv::drawContours(bgr, contours, -1, cv::Scalar(0, 255, 0), thickness);
  return bgr;
}

}  // namespace dome::silhouette
