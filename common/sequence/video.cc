#include "sequence/video.h"

#include <cstdio>

#include "core/error.h"

namespace dome::sequence {

void VideoOptions::Check() const {
  core::Require(crf >= 0 && crf <= 51, "export: crf", "must be 0 (lossless) .. 51");
  static const char* kPresets[] = {"ultrafast", "superfast", "veryfast", "faster", "fast",
                                   "medium",    "slow",      "slower",   "veryslow"};
  bool known = false;
  for (const char* p : kPresets) known = known || preset == p;
  core::Require(known, "export: preset",
                "must be one of x264's presets ultrafast .. veryslow, not '" + preset + "'");
  core::Require(keyframe_every >= 1 && keyframe_every <= 600, "export: keyframe_every",
                "must be 1..600 frames");
  core::Require(threads >= 0 && threads <= 64, "export: threads", "must be 0..64");
}

namespace {

// "avc1.PPCCLL" from the first SPS (NAL type 7) of an Annex B packet; "" when none.
std::string CodecOf(const std::string& annex_b) {
  for (size_t i = 0; i + 6 < annex_b.size(); ++i) {
    if (annex_b[i] == 0 && annex_b[i + 1] == 0 && annex_b[i + 2] == 1 &&
        (annex_b[i + 3] & 0x1f) == 7) {
      char text[16];
      std::snprintf(text, sizeof text, "avc1.%02x%02x%02x", uint8_t(annex_b[i + 4]),
                    uint8_t(annex_b[i + 5]), uint8_t(annex_b[i + 6]));
      return text;
    }
  }
  return "";
}

}  // namespace

struct VideoEncoder::State {
  std::unique_ptr<video::H264Encoder> encoder;
  cv::Mat canvas;  // W x H BGR, black around the atlas
};

VideoEncoder::VideoEncoder(int width, int height, double fps, const VideoOptions& options)
    : state_(std::make_unique<State>()) {
  options.Check();
  core::Require(width > 0 && height > 0 && width % 2 == 0 && height % 2 == 0 &&
                    width <= 8192 && height <= 8192,
                "export: video frame", "must be even sizes up to 8192 (H.264 4:2:0)");
  video::H264Settings settings;
  settings.width = width;
  settings.height = height;
  settings.fps = fps;
  settings.crf = options.crf;
  settings.preset = options.preset;
  settings.keyframe_every = options.keyframe_every;
  settings.threads = options.threads;
  state_->encoder = video::CreateH264Encoder(settings, "export: video");
  state_->canvas = cv::Mat(height, width, CV_8UC3, cv::Scalar(0, 0, 0));
}

VideoEncoder::~VideoEncoder() = default;

std::vector<VideoPacket> VideoEncoder::Encode(const cv::Mat& bgr) {
  State& s = *state_;
  core::Require(bgr.type() == CV_8UC3 && bgr.cols <= s.canvas.cols && bgr.rows <= s.canvas.rows,
                "export: atlas", "must be 8-bit BGR within the video frame");
  s.canvas.setTo(cv::Scalar(0, 0, 0));
  bgr.copyTo(s.canvas(cv::Rect(0, 0, bgr.cols, bgr.rows)));
  return Drain(s.canvas);
}

std::vector<VideoPacket> VideoEncoder::Flush() { return Drain(cv::Mat()); }

std::vector<VideoPacket> VideoEncoder::Drain(const cv::Mat& frame) {
  std::vector<VideoPacket> out;
  std::string error;
  const bool ok = state_->encoder->Encode(frame, frame.empty() ? -1 : next_frame_++, &out, &error);
  core::Require(ok, "export: video", error);
  for (const VideoPacket& p : out) {
    if (codec_.empty()) codec_ = CodecOf(p.bytes);
  }
  return out;
}

struct VideoDecoder::State {
  std::unique_ptr<video::H264Decoder> decoder;
};

VideoDecoder::VideoDecoder() : state_(std::make_unique<State>()) {
  state_->decoder = video::CreateH264Decoder("4D stream: video");
}

VideoDecoder::~VideoDecoder() = default;

std::vector<cv::Mat> VideoDecoder::Decode(std::string_view bytes, const std::string& where) {
  core::Require(!bytes.empty(), where, "empty H.264 packet");
  return Receive(bytes, where);
}

std::vector<cv::Mat> VideoDecoder::Flush() { return Receive({}, "4D stream: video"); }

std::vector<cv::Mat> VideoDecoder::Receive(std::string_view bytes, const std::string& where) {
  std::vector<cv::Mat> out;
  std::string error;
  core::Require(state_->decoder->Decode(bytes, &out, &error), where, error);
  return out;
}

}  // namespace dome::sequence
