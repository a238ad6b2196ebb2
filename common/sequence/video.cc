#include "sequence/video.h"

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavutil/opt.h>
#include <libswscale/swscale.h>
}

#include <cmath>
#include <cstdio>
#include <cstring>

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

std::string AvError(int rc) {
  char text[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(rc, text, sizeof text);
  return text;
}

// BT.601, limited range, on both sides of the conversion (what the VUI says).
void SetBt601(SwsContext* sws, bool to_yuv) {
  const int* coefficients = sws_getCoefficients(SWS_CS_ITU601);
  sws_setColorspaceDetails(sws, coefficients, to_yuv ? 1 : 0, coefficients, to_yuv ? 0 : 1, 0,
                           1 << 16, 1 << 16);
}

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
  AVCodecContext* ctx = nullptr;
  AVFrame* frame = nullptr;
  AVPacket* packet = nullptr;
  SwsContext* sws = nullptr;
  cv::Mat canvas;  // W x H BGR, black around the atlas
  ~State() {
    sws_freeContext(sws);
    av_packet_free(&packet);
    av_frame_free(&frame);
    avcodec_free_context(&ctx);
  }
};

VideoEncoder::VideoEncoder(int width, int height, double fps, const VideoOptions& options)
    : state_(std::make_unique<State>()) {
  options.Check();
  core::Require(width > 0 && height > 0 && width % 2 == 0 && height % 2 == 0 &&
                    width <= 8192 && height <= 8192,
                "export: video frame", "must be even sizes up to 8192 (H.264 4:2:0)");
  // libx264's statistics lines are not dome's to print; its errors still are.
  av_log_set_level(AV_LOG_ERROR);
  const AVCodec* codec = avcodec_find_encoder_by_name("libx264");
  core::Require(codec != nullptr, "export: video",
                "this libavcodec has no libx264 encoder (Debian's libavcodec59 has)");
  State& s = *state_;
  s.ctx = avcodec_alloc_context3(codec);
  s.ctx->width = width;
  s.ctx->height = height;
  s.ctx->pix_fmt = AV_PIX_FMT_YUV420P;
  const int rate = int(std::lround(fps * 1000));
  s.ctx->time_base = AVRational{1000, rate};
  s.ctx->framerate = AVRational{rate, 1000};
  s.ctx->gop_size = options.keyframe_every;
  s.ctx->keyint_min = options.keyframe_every;
  s.ctx->max_b_frames = 0;
  s.ctx->thread_count = options.threads;
  s.ctx->colorspace = AVCOL_SPC_SMPTE170M;
  s.ctx->color_primaries = AVCOL_PRI_SMPTE170M;
  s.ctx->color_trc = AVCOL_TRC_SMPTE170M;
  s.ctx->color_range = AVCOL_RANGE_MPEG;
  av_opt_set(s.ctx->priv_data, "preset", options.preset.c_str(), 0);
  av_opt_set(s.ctx->priv_data, "crf", std::to_string(options.crf).c_str(), 0);
  // Texture atlases have no scene cuts to find; keyframes only where asked.
  av_opt_set(s.ctx->priv_data, "x264-params", "scenecut=0", 0);
  const int rc = avcodec_open2(s.ctx, codec, nullptr);
  core::Require(rc >= 0, "export: video", "libx264 refused the settings: " + AvError(rc));
  s.frame = av_frame_alloc();
  s.frame->format = AV_PIX_FMT_YUV420P;
  s.frame->width = width;
  s.frame->height = height;
  DOME_CHECK(av_frame_get_buffer(s.frame, 0) >= 0, "av_frame_get_buffer failed");
  s.packet = av_packet_alloc();
  s.sws = sws_getContext(width, height, AV_PIX_FMT_BGR24, width, height, AV_PIX_FMT_YUV420P,
                         SWS_BILINEAR, nullptr, nullptr, nullptr);
  DOME_CHECK(s.sws != nullptr, "sws_getContext failed");
  SetBt601(s.sws, true);
  s.canvas = cv::Mat(height, width, CV_8UC3, cv::Scalar(0, 0, 0));
}

VideoEncoder::~VideoEncoder() = default;

std::vector<VideoPacket> VideoEncoder::Encode(const cv::Mat& bgr) {
  State& s = *state_;
  core::Require(bgr.type() == CV_8UC3 && bgr.cols <= s.canvas.cols && bgr.rows <= s.canvas.rows,
                "export: atlas", "must be 8-bit BGR within the video frame");
  s.canvas.setTo(cv::Scalar(0, 0, 0));
  bgr.copyTo(s.canvas(cv::Rect(0, 0, bgr.cols, bgr.rows)));
  DOME_CHECK(av_frame_make_writable(s.frame) >= 0, "av_frame_make_writable failed");
  const uint8_t* src[1] = {s.canvas.data};
  const int stride[1] = {int(s.canvas.step)};
  sws_scale(s.sws, src, stride, 0, s.canvas.rows, s.frame->data, s.frame->linesize);
  s.frame->pts = next_frame_++;
  const int rc = avcodec_send_frame(s.ctx, s.frame);
  core::Require(rc >= 0, "export: video", "libx264 refused a frame: " + AvError(rc));
  return Drain();
}

std::vector<VideoPacket> VideoEncoder::Flush() {
  avcodec_send_frame(state_->ctx, nullptr);
  return Drain();
}

std::vector<VideoPacket> VideoEncoder::Drain() {
  State& s = *state_;
  std::vector<VideoPacket> out;
  while (true) {
    const int rc = avcodec_receive_packet(s.ctx, s.packet);
    if (rc == AVERROR(EAGAIN) || rc == AVERROR_EOF) break;
    core::Require(rc >= 0, "export: video", "libx264 failed: " + AvError(rc));
    VideoPacket p;
    p.frame = s.packet->pts;
    p.keyframe = (s.packet->flags & AV_PKT_FLAG_KEY) != 0;
    p.bytes.assign(reinterpret_cast<const char*>(s.packet->data), size_t(s.packet->size));
    if (codec_.empty()) codec_ = CodecOf(p.bytes);
    out.push_back(std::move(p));
    av_packet_unref(s.packet);
  }
  return out;
}

struct VideoDecoder::State {
  AVCodecContext* ctx = nullptr;
  AVFrame* frame = nullptr;
  AVPacket* packet = nullptr;
  SwsContext* sws = nullptr;
  ~State() {
    sws_freeContext(sws);
    av_packet_free(&packet);
    av_frame_free(&frame);
    avcodec_free_context(&ctx);
  }
};

VideoDecoder::VideoDecoder() : state_(std::make_unique<State>()) {
  const AVCodec* codec = avcodec_find_decoder(AV_CODEC_ID_H264);
  core::Require(codec != nullptr, "4D stream: video", "this libavcodec has no H.264 decoder");
  State& s = *state_;
  s.ctx = avcodec_alloc_context3(codec);
  s.ctx->thread_count = 1;  // frames come out as their packets go in
  DOME_CHECK(avcodec_open2(s.ctx, codec, nullptr) >= 0, "avcodec_open2 (h264) failed");
  s.frame = av_frame_alloc();
  s.packet = av_packet_alloc();
}

VideoDecoder::~VideoDecoder() = default;

std::vector<cv::Mat> VideoDecoder::Decode(std::string_view bytes, const std::string& where) {
  State& s = *state_;
  DOME_CHECK(av_new_packet(s.packet, int(bytes.size())) >= 0, "av_new_packet failed");
  std::memcpy(s.packet->data, bytes.data(), bytes.size());
  const int rc = avcodec_send_packet(s.ctx, s.packet);
  av_packet_unref(s.packet);
  core::Require(rc >= 0, where, "H.264 packet does not decode: " + AvError(rc));
  return Receive(where);
}

std::vector<cv::Mat> VideoDecoder::Flush() {
  avcodec_send_packet(state_->ctx, nullptr);
  return Receive("4D stream: video");
}

std::vector<cv::Mat> VideoDecoder::Receive(const std::string& where) {
  State& s = *state_;
  std::vector<cv::Mat> out;
  while (true) {
    const int rc = avcodec_receive_frame(s.ctx, s.frame);
    if (rc == AVERROR(EAGAIN) || rc == AVERROR_EOF) break;
    core::Require(rc >= 0, where, "H.264 frame does not decode: " + AvError(rc));
    const int w = s.frame->width, h = s.frame->height;
    s.sws = sws_getCachedContext(s.sws, w, h, AVPixelFormat(s.frame->format), w, h,
                                 AV_PIX_FMT_BGR24, SWS_BILINEAR, nullptr, nullptr, nullptr);
    DOME_CHECK(s.sws != nullptr, "sws_getCachedContext failed");
    SetBt601(s.sws, false);
    // libswscale's vector code may write past the end of a row and of the last row of
    // an output whose width is not a multiple of its vector size: give it room.
    cv::Mat padded(h + 2, w + 64, CV_8UC3);
    uint8_t* dst[1] = {padded.data};
    const int stride[1] = {int(padded.step)};
    sws_scale(s.sws, s.frame->data, s.frame->linesize, 0, h, dst, stride);
    out.push_back(padded(cv::Rect(0, 0, w, h)).clone());
    av_frame_unref(s.frame);
  }
  return out;
}

}  // namespace dome::sequence
