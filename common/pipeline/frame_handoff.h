// Frames decoded before a session's jobs run, handed to the in-process workers' jobs.
//
// `dome run` derives the session from one instant's frames (pipeline/derive.h), then its
// embedded workers' stereo jobs decode the same files again. The derivation offers each
// frame it decoded here, under the SHA-256 of the file's bytes (the address a job's
// blob carries, net/content_hash.h), and a job that needs that blob takes the decoded
// image instead of decoding it (jobs.cc: FrameBlobs). Images are as
// stereo::DecodeFrame gives them (io::ImageMode::kUnchanged).
//
// Process-wide and thread-safe. At most kBudgetBytes of pixels are held, the oldest
// dropped first; a frame is handed over once (kept for the process's jobs from there,
// below), so nothing stays in the handoff after the jobs have run. Offer only where
// in-process workers will run: a frame nobody takes is held until the process ends.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "io/image_io.h"

namespace dome::pipeline {

constexpr size_t kFrameHandoffBudgetBytes = size_t(256) << 20;

// Holds `image` (decoded unchanged) for the job whose blob has address `sha256`.
void OfferDecodedFrame(const std::string& sha256, const cv::Mat& image);

// The image offered under `sha256`, removed from the handoff; empty when none is held.
cv::Mat TakeDecodedFrame(const std::string& sha256);

// Frames held now (for tests).
size_t HeldDecodedFrames();

// Frames decoded by this process's workers' jobs, kept for its other jobs (jobs.cc:
// FrameBlobs): a frame is the reference of one stereo job of its instant, a neighbour in
// two to four more, and a view of the texture job, and `dome run`'s two embedded workers
// each decoded it for themselves (a tenth of a masked paper stereo job). Kept under the
// frame's address and the mode it was decoded in; at most kKeptFramesBudgetBytes of
// pixels, the oldest dropped first (an instant's frames come in camera order, and a
// stereo job's neighbours are its nearest cameras).
constexpr size_t kKeptFramesBudgetBytes = size_t(512) << 20;
// The frame kept under `sha256` as decoded in `mode`, or empty. A frame kept as decoded
// unchanged serves a BGR request when it is 8-bit BGR, or 8-bit BGRA whose colour
// channels are what decoding it as BGR gives (PNG's alpha is dropped, not composited).
cv::Mat FindKeptFrame(const std::string& sha256, io::ImageMode mode);
// Keeps `image`, `sha256`'s frame decoded in `mode`; returns the one kept (the first one
// kept when two jobs decoded it at once: the same bytes give the same image).
cv::Mat KeepFrame(const std::string& sha256, io::ImageMode mode, const cv::Mat& image);
// Frames kept now, and dropping them all (for tests).
size_t KeptFrames();
void DropKeptFrames();

// Masks the derivation made for the masks' hull volume (pipeline/derive.h), handed to
// the masks stage's jobs of this process, which would make the same masks again (the
// paper take: every mask of every instant, a sixth of the session's job seconds). The
// key names what a job makes its mask from: its camera, its source (MaskJob.source) and
// the content addresses of its blobs after the rig, in order. At most
// kMaskHandoffBudgetBytes are held, the oldest dropped first; a mask is handed over once.
constexpr size_t kMaskHandoffBudgetBytes = size_t(128) << 20;
std::string MaskHandoffKey(const std::string& camera, const std::string& source,
                           const std::vector<std::string>& input_sha256);
void OfferMask(const std::string& key, const cv::Mat& mask);
// The mask offered under `key`, removed from the handoff; empty when none is held.
cv::Mat TakeMask(const std::string& key);

}  // namespace dome::pipeline
