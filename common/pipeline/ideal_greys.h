// Ideal greys of frames (stereo/multi_baseline.h IdealGrey), kept for every stereo job
// of this process.
//
// A frame is the reference of one stereo job of its instant and a neighbour in about two
// more; each job would undistort and stretch it again (the paper take: about a tenth of a
// job with masks). The stereo stage keeps each grey here under a key of what it was made
// from: the frame's blob address (SHA-256 of its bytes, net/content_hash.h), the rig's
// (the camera's lens) and the grey mapping; every worker of the process (dome run's
// embedded ones) finds it. A grey is the same bits however many jobs use it.
//
// Process-wide and thread-safe. At most kIdealGreysBudgetBytes of greys are held, the
// oldest dropped first (two instants of the paper take: 51 cameras of 640x480 floats,
// 63 MB an instant).
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "stereo/multi_baseline.h"

namespace dome::pipeline {

constexpr size_t kIdealGreysBudgetBytes = size_t(128) << 20;

// The key of a frame's ideal grey: the frame's and the rig's blob addresses, the camera
// and the options' grey mapping (normalize_contrast, sqrt_greys).
std::string IdealGreyKey(const std::string& frame_sha256, const std::string& rig_sha256,
                         const std::string& camera, const stereo::StereoOptions& options);

// The key of the grey of a frame's view cut to `rect` (coarse to fine's clip box cut,
// pipeline/stages.h Stereo): `frame_key` (IdealGreyKey) and the rectangle.
std::string CutGreyKey(const std::string& frame_key, const cv::Rect& rect);

// The grey kept under `key`, or one made by stereo::IdealGrey(view, options, where) and
// kept. The image returned is shared: callers must not write to it.
cv::Mat SharedIdealGrey(const std::string& key, const stereo::StereoView& view,
                        const stereo::StereoOptions& options, const std::string& where);

// Greys held now, and dropping them all (for tests: a test that puts another image under a
// frame's address must not find the real frame's grey).
size_t HeldIdealGreys();
void DropIdealGreys();

}  // namespace dome::pipeline
