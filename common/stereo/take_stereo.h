// Stereo over a take: every (instant, reference camera) job, read from the take folder
// and written to an output folder.
//
// Output layout (DIR = the output folder):
//   DIR/<instant>/depth/<camera>.tiff         first window size: z-depth along the
//                                             reference optical axis, 32-bit float, mm,
//                                             0 = invalid (io/depth_tiff.h; the same
//                                             encoding as TAKE/truth/<instant>/depth/)
//   DIR/<instant>/reliability/<camera>.tiff   32-bit float TIFF: cost curvature per
//                                             sample at the minimum (grey^2 per level^2),
//                                             0 = invalid
//   DIR/<instant>/preview/<camera>.png        colour-mapped depth (io DepthPreview)
// Each further window size N writes the same three files under depth-wN/,
// reliability-wN/ and preview-wN/ (seed §5: each window's result is its own range
// image for fusion).
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "stereo/cluster.h"
#include "stereo/coarse_to_fine.h"
#include "stereo/multi_baseline.h"
#include "take/take.h"

namespace dome::stereo {

struct TakeStereoOptions {
  StereoOptions stereo;
  ClusterOptions cluster;
  bool write_previews = true;  // preview PNGs beside the depth maps
  // Present: coarse-to-fine stereo over tiles (stereo/coarse_to_fine.h), each camera's
  // range clipped to its box; absent: the full-range search (pipeline/stages.h Stereo).
  std::optional<CoarseToFineOptions> coarse_to_fine;
  // A clip box for the full-range search (clip = true; world frame, mm): each reference
  // camera searches only the depths of the part of the box it sees
  // (ClipDepthRangeToVisibleBox), widened by clip_pad_mm.
  bool clip = false;
  Eigen::Vector3d clip_min_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d clip_max_mm = Eigen::Vector3d::Zero();
  double clip_pad_mm = 2.0;
  // Per camera id, the depths (z_min, z_max along its axis, mm) its search is limited
  // to, within the range above; cameras not named search the whole range.
  std::map<std::string, std::pair<double, double>> camera_depth_mm;

  // Throws core::InputError naming the first option out of range.
  void Check() const;
};

// A frame as stereo takes it: 8-bit gray, BGR or BGRA (alpha kept: it marks valid
// pixels). Throws core::InputError naming the file otherwise.
cv::Mat ReadFrame(const std::filesystem::path& path);
// The same from the file's bytes; `where` names them in errors.
cv::Mat DecodeFrame(std::string_view bytes, const std::string& where);
// `image` (decoded unchanged) as DecodeFrame returns it; throws core::InputError naming
// `where` when it is not such a frame.
const cv::Mat& CheckFrame(const cv::Mat& image, const std::string& where);

// The stereo input of one job: the reference camera's frame at `instant` and its
// cluster's frames, read from the take (errors name the files).
StereoInput LoadStereoInput(const take::Take& take, const std::string& instant,
                            const std::string& camera_id, const ClusterOptions& cluster);

// One output file of a stereo result: its path under DIR/<instant>/ (layout above) and
// its bytes.
struct StereoFile {
  std::string path;
  std::string bytes;
};

// The files of one result, in layout order (per window: depth, reliability, preview).
// A worker encodes them (one file per thread of `num_threads`; <= 0: the hardware's,
// 1: on the calling thread); the master checks and writes them.
std::vector<StereoFile> EncodeStereoFiles(const StereoResult& result, bool write_previews,
                                          int num_threads = 1);

// Where the maps of a range image lie when they are a rectangle cut from the full maps
// (as a stereo result travels, pipeline/jobs.h DecodeStereoRects): their top-left corner
// in the full maps, pixels, and the full maps' size. Outside the rectangle every value
// is 0.
struct MapCut {
  cv::Point at;
  cv::Size full;
};

// Throws core::InputError naming `where` and the file unless `files` are exactly the
// files of `result`: the layout's paths, the depth and reliability maps decoding to the
// result's values bit for bit, previews with the PNG header of a colour image of the
// map's size (their pixels are not checked). With `cuts` (one per range image) the
// result's maps are rectangles of the full maps (MapCut), compared as placed there.
void CheckStereoFiles(const StereoResult& result, bool write_previews,
                      const std::vector<StereoFile>& files, const std::string& where,
                      const std::vector<MapCut>& cuts = {});

// Writes files under `out_dir`/`instant`; returns the depth paths written.
std::vector<std::filesystem::path> WriteStereoFiles(const std::vector<StereoFile>& files,
                                                    const std::string& instant,
                                                    const std::filesystem::path& out_dir);

// Writes one result under `out_dir` (layout above) and returns the depth paths written,
// one per window size.
std::vector<std::filesystem::path> WriteStereoResult(const StereoResult& result,
                                                     const std::string& instant,
                                                     const std::filesystem::path& out_dir,
                                                     bool write_previews);

}  // namespace dome::stereo
