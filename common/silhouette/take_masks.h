// Foreground masks of a take's frames (take/take.h), per camera and instant.
//
// Where a camera's masks come from, in this order:
//   1. given:  TAKE/masks/<instant>/<camera>.png  -- 8-bit gray (or any 8-bit PNG whose
//              first channel is read), nonzero = foreground; one per instant of the take.
//   2. plate:  TAKE/background/<camera>.png       -- the empty scene as the camera sees it
//              (8-bit gray, BGR or BGRA like the frames); each frame is compared with it
//              (silhouette/background.h).
//   3. median: neither exists -- the background is the per-pixel median of the camera's
//              frames over the take's instants, arbitrated by the smooth background
//              where the instants disagree (background.h ConsensusBackground). Where the person
//              stands in one instant they are elsewhere in most others, if the instants are far
//              enough apart in time and there are at least kMinMedianInstants of them; with fewer,
//              no median exists and opening the masks fails, naming the take and the folders that
//              would help.
// A given mask or plate of another size than rig.json's camera is an error naming the
// file and both sizes. Frames with alpha: pixels with alpha 0 have no data and are
// background in every mask.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "silhouette/background.h"
#include "take/take.h"

namespace dome::silhouette {

enum class MaskSource { kGiven, kPlate, kMedian };
const char* MaskSourceName(MaskSource source);  // "given", "plate", "median"

struct MaskOptions {
  ForegroundOptions foreground;
  CleanupOptions cleanup;
  // The median background uses at most this many instants (count), spread evenly over
  // the take (first and last included): more instants are further apart on average
  // only up to the take's length, and memory grows with the count.
  int median_max_instants = 15;

  // The fewest instants a median background needs: with two, the median is one of the
  // two frames and a person in either leaves a ghost; with three, a pixel is background
  // when the person covers it in at most one of them.
  static constexpr int kMinMedianInstants = 3;

  void Check() const;
};

// What one mask came from and looked like.
struct MaskInfo {
  MaskSource source = MaskSource::kMedian;
  double fraction = 0.0;  // foreground pixels / pixels, after clean-up
  ForegroundStats stats;  // of the classification (not for given masks)
};

// Each camera's source as TakeMasks decides it, from which files exist (nothing is
// read, so it is cheap): given when any instant has a given mask, else plate, else
// median. Throws core::InputError naming the take when a camera needs a median and
// the take has fewer than kMinMedianInstants instants (TakeMasks also checks the
// given masks' and plates' kinds and sizes).
std::map<std::string, MaskSource> DecideMaskSources(const take::Take& take);

class TakeMasks {
 public:
  // Decides each camera's source and checks the given masks' and plates' sizes, so
  // that errors surface before any work. Throws core::InputError naming the file (a
  // mask or plate of the wrong size or kind, a given mask missing for an instant) or
  // the take (too few instants for a median).
  TakeMasks(take::Take take, const MaskOptions& options);

  const take::Take& take() const { return take_; }
  MaskSource Source(const std::string& camera) const;
  // What the consensus found for a median camera's background (background.h), once a
  // Mask() of that camera has made it; zeros before, and for plates and given masks.
  ConsensusStats BackgroundConsensus(const std::string& camera) const;

  // The mask (CV_8UC1, 255 / 0, the camera's size) of `camera` at `instant`. Reads the
  // frames it needs; the median background is computed on first use and kept.
  // Thread-safe for distinct cameras.
  cv::Mat Mask(const std::string& instant, const std::string& camera, MaskInfo* info = nullptr);

  // How frame files are read (the image decoded unchanged, io::ImageMode::kUnchanged),
  // from Mask's threads; by default each read decodes the file. The session's derivation
  // reads every frame once for the masks, their hull and the scene's extent
  // (pipeline/derive.cc).
  using FrameReader = std::function<cv::Mat(const std::filesystem::path& path)>;
  void SetFrameReader(FrameReader reader) { frame_reader_ = std::move(reader); }
  // Called with each frame file Mask reads for the frame itself (its path, and the image
  // as read) before the mask is made from it, from Mask's threads: `dome run` hands the
  // decoded frames to its workers' stereo jobs (pipeline/frame_handoff.h).
  using FrameSeen = std::function<void(const std::filesystem::path& path, const cv::Mat& image)>;
  void SetFrameSeen(FrameSeen seen) { frame_seen_ = std::move(seen); }

  std::filesystem::path GivenMaskPath(const std::string& instant, const std::string& camera) const;
  std::filesystem::path PlatePath(const std::string& camera) const;
  // The files Mask(instant, camera) is made from, in the order the masks stage's job
  // takes them (pipeline/session.cc PlanMasks): the given mask; or the frame and the
  // plate; or the frame and the camera's frames at the median's instants.
  std::vector<std::filesystem::path> InputPaths(const std::string& instant,
                                                const std::string& camera) const;

 private:
  // The background of `camera` (plate or median), in the frames' colour (gray or BGR).
  const cv::Mat& Background(const std::string& camera, int channels);

  take::Take take_;
  MaskOptions options_;
  std::map<std::string, MaskSource> sources_;
  std::map<std::string, cv::Mat> backgrounds_;  // one entry per camera, filled on use
  std::map<std::string, ConsensusStats> consensus_;  // the same, for median cameras
  // A frame file decoded unchanged, through frame_reader_ when set.
  cv::Mat ReadRaw(const std::filesystem::path& path) const;
  FrameReader frame_reader_;
  FrameSeen frame_seen_;
};

// The instants a median background uses: at most `max_count`, evenly spread over
// `instants` (indices rounded), first and last included.
std::vector<std::string> MedianInstants(const std::vector<std::string>& instants, int max_count);

// A frame split into colour (CV_8UC1 or CV_8UC3) and valid pixels (CV_8UC1, empty when
// the file has no alpha).
struct Frame {
  cv::Mat colour;
  cv::Mat valid;
};
// Reads a frame or plate: 8-bit gray, BGR or BGRA. Throws core::InputError naming the
// file when it is another kind, or not `size` (rig.json's size of `camera`).
Frame ReadFrame(const std::filesystem::path& path, cv::Size size, const std::string& camera);
// The same for an image already decoded unchanged (io::ImageMode::kUnchanged), errors
// naming `where`.
Frame SplitFrame(const cv::Mat& raw, cv::Size size, const std::string& camera,
                 const std::string& where);
// A given mask decoded unchanged as 255 / 0 (its first channel nonzero). Throws
// core::InputError naming `where` unless it is 8-bit of `size`.
cv::Mat MaskImage(const cv::Mat& raw, cv::Size size, const std::string& camera,
                  const std::string& where);

// The consensus of one camera's frame colours (ReadFrame), in `channels` channels
// (background.h ConsensusBackground): the median background TakeMasks uses.
cv::Mat MedianBackground(const std::vector<cv::Mat>& colours, int channels,
                         ConsensusStats* stats = nullptr);
// The mask of `frame` against `background` (a plate, or a median background when
// `source` is kMedian), as TakeMasks::Mask makes it: classified (background.h), then
// cleaned; `info` gets its source, statistics and foreground fraction.
cv::Mat MaskAgainst(const Frame& frame, const cv::Mat& background, MaskSource source,
                    const MaskOptions& options, MaskInfo* info = nullptr);

// The image darkened to a third outside the mask, with the mask's outline in green: for
// looking at a mask (BGR, the image's size).
cv::Mat MaskPreview(const cv::Mat& image, const cv::Mat& mask);

}  // namespace dome::silhouette
