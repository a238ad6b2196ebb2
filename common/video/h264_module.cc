// H.264 through libavcodec (libx264) and libswscale, inside the video module.
#include "video/h264_module.h"

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavutil/opt.h>
#include <libswscale/swscale.h>
}

#include <cmath>
#include <cstring>

namespace dome::video {
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

// What libavcodec and libswscale hold for one coder.
struct AvState {
  AVCodecContext* ctx = nullptr;
  AVFrame* frame = nullptr;
  AVPacket* packet = nullptr;
  SwsContext* sws = nullptr;
  ~AvState() {
    sws_freeContext(sws);
    av_packet_free(&packet);
    av_frame_free(&frame);
    avcodec_free_context(&ctx);
  }
};

class Encoder final : public H264Encoder {
 public:
  // false, saying why, when libx264 is missing or refuses the settings.
  bool Open(const H264Settings& o, std::string* error) {
    // libx264's statistics lines are not dome's to print; its errors still are.
    av_log_set_level(AV_LOG_ERROR);
    const AVCodec* codec = avcodec_find_encoder_by_name("libx264");
    if (!codec) {
      *error = "this libavcodec has no libx264 encoder (Debian's libavcodec59 has)";
      return false;
    }
    s_.ctx = avcodec_alloc_context3(codec);
    s_.ctx->width = o.width;
    s_.ctx->height = o.height;
    s_.ctx->pix_fmt = AV_PIX_FMT_YUV420P;
    const int rate = int(std::lround(o.fps * 1000));
    s_.ctx->time_base = AVRational{1000, rate};
    s_.ctx->framerate = AVRational{rate, 1000};
    s_.ctx->gop_size = o.keyframe_every;
    s_.ctx->keyint_min = o.keyframe_every;
    s_.ctx->max_b_frames = 0;
    s_.ctx->thread_count = o.threads;
    s_.ctx->colorspace = AVCOL_SPC_SMPTE170M;
    s_.ctx->color_primaries = AVCOL_PRI_SMPTE170M;
    s_.ctx->color_trc = AVCOL_TRC_SMPTE170M;
    s_.ctx->color_range = AVCOL_RANGE_MPEG;
    av_opt_set(s_.ctx->priv_data, "preset", o.preset.c_str(), 0);
    av_opt_set(s_.ctx->priv_data, "crf", std::to_string(o.crf).c_str(), 0);
    // Texture atlases have no scene cuts to find; keyframes only where asked.
    av_opt_set(s_.ctx->priv_data, "x264-params", "scenecut=0", 0);
    const int rc = avcodec_open2(s_.ctx, codec, nullptr);
    if (rc < 0) {
      *error = "libx264 refused the settings: " + AvError(rc);
      return false;
    }
    s_.frame = av_frame_alloc();
    s_.frame->format = AV_PIX_FMT_YUV420P;
    s_.frame->width = o.width;
    s_.frame->height = o.height;
    s_.packet = av_packet_alloc();
    s_.sws = sws_getContext(o.width, o.height, AV_PIX_FMT_BGR24, o.width, o.height,
                            AV_PIX_FMT_YUV420P, SWS_BILINEAR, nullptr, nullptr, nullptr);
    if (av_frame_get_buffer(s_.frame, 0) < 0 || !s_.packet || !s_.sws) {
      *error = "out of memory for the encoder's frame";
      return false;
    }
    SetBt601(s_.sws, true);
    return true;
  }

  bool Encode(const cv::Mat& bgr, int64_t index, std::vector<H264Packet>* out,
              std::string* error) override {
    int rc = 0;
    if (bgr.empty()) {
      rc = avcodec_send_frame(s_.ctx, nullptr);
      if (rc == AVERROR_EOF) rc = 0;  // flushed before
    } else {
      if (av_frame_make_writable(s_.frame) < 0) {
        *error = "out of memory for a frame";
        return false;
      }
      const uint8_t* src[1] = {bgr.data};
      const int stride[1] = {int(bgr.step)};
      sws_scale(s_.sws, src, stride, 0, bgr.rows, s_.frame->data, s_.frame->linesize);
      s_.frame->pts = index;
      rc = avcodec_send_frame(s_.ctx, s_.frame);
    }
    if (rc < 0) {
      *error = "libx264 refused a frame: " + AvError(rc);
      return false;
    }
    while (true) {
      rc = avcodec_receive_packet(s_.ctx, s_.packet);
      if (rc == AVERROR(EAGAIN) || rc == AVERROR_EOF) return true;
      if (rc < 0) {
        *error = "libx264 failed: " + AvError(rc);
        return false;
      }
      H264Packet p;
      p.frame = s_.packet->pts;
      p.keyframe = (s_.packet->flags & AV_PKT_FLAG_KEY) != 0;
      p.bytes.assign(reinterpret_cast<const char*>(s_.packet->data), size_t(s_.packet->size));
      out->push_back(std::move(p));
      av_packet_unref(s_.packet);
    }
  }

 private:
  AvState s_;
};

class Decoder final : public H264Decoder {
 public:
  bool Open(std::string* error) {
    const AVCodec* codec = avcodec_find_decoder(AV_CODEC_ID_H264);
    if (!codec) {
      *error = "this libavcodec has no H.264 decoder";
      return false;
    }
    s_.ctx = avcodec_alloc_context3(codec);
    s_.ctx->thread_count = 1;  // frames come out as their packets go in
    const int rc = avcodec_open2(s_.ctx, codec, nullptr);
    if (rc < 0) {
      *error = "the H.264 decoder does not open: " + AvError(rc);
      return false;
    }
    s_.frame = av_frame_alloc();
    s_.packet = av_packet_alloc();
    if (!s_.frame || !s_.packet) {
      *error = "out of memory for the decoder";
      return false;
    }
    return true;
  }

  bool Decode(std::string_view bytes, std::vector<cv::Mat>* out, std::string* error) override {
    int rc = 0;
    if (bytes.empty()) {
      rc = avcodec_send_packet(s_.ctx, nullptr);
      if (rc == AVERROR_EOF) rc = 0;  // flushed before
    } else {
      if (av_new_packet(s_.packet, int(bytes.size())) < 0) {
        *error = "out of memory for a packet";
        return false;
      }
      std::memcpy(s_.packet->data, bytes.data(), bytes.size());
      rc = avcodec_send_packet(s_.ctx, s_.packet);
      av_packet_unref(s_.packet);
    }
    if (rc < 0) {
      *error = "H.264 packet does not decode: " + AvError(rc);
      return false;
    }
    while (true) {
      rc = avcodec_receive_frame(s_.ctx, s_.frame);
      if (rc == AVERROR(EAGAIN) || rc == AVERROR_EOF) return true;
      if (rc < 0) {
        *error = "H.264 frame does not decode: " + AvError(rc);
        return false;
      }
      const int w = s_.frame->width, h = s_.frame->height;
      s_.sws = sws_getCachedContext(s_.sws, w, h, AVPixelFormat(s_.frame->format), w, h,
                                    AV_PIX_FMT_BGR24, SWS_BILINEAR, nullptr, nullptr, nullptr);
      if (!s_.sws) {
        *error = "libswscale cannot convert this frame to BGR";
        return false;
      }
      SetBt601(s_.sws, false);
      // libswscale's vector code may write past the end of a row and of the last row of
      // an output whose width is not a multiple of its vector size: give it room.
      cv::Mat padded(h + 2, w + 64, CV_8UC3);
      uint8_t* dst[1] = {padded.data};
      const int stride[1] = {int(padded.step)};
      sws_scale(s_.sws, s_.frame->data, s_.frame->linesize, 0, h, dst, stride);
      out->push_back(padded(cv::Rect(0, 0, w, h)).clone());
      av_frame_unref(s_.frame);
    }
  }

 private:
  AvState s_;
};

}  // namespace

H264Encoder* NewH264Encoder(const H264Settings& settings, std::string* error) {
  auto* e = new Encoder;
  if (e->Open(settings, error)) return e;
  delete e;
  return nullptr;
}

H264Decoder* NewH264Decoder(std::string* error) {
  auto* d = new Decoder;
  if (d->Open(error)) return d;
  delete d;
  return nullptr;
}

}  // namespace dome::video
