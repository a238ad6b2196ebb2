// The texture atlases of a sequence as frames of one H.264 video stream (ffmpeg's
// libavcodec with libx264, in dome's video module: video/video.h), and its reference
// decoder.
//
// Frames: BGR (OpenCV) atlases at the top-left of a fixed W x H frame (even sizes, the
// rest black), converted to 4:2:0 YUV with BT.601 limited-range coefficients
// (libswscale; the same matrix is written in the stream's VUI, so browsers convert
// back with it). Packets are Annex B byte streams (start codes, SPS/PPS before every
// keyframe), one per frame, in frame order: no B-frames, so decode order is display
// order, and a keyframe every `keyframe_every` frames (1: every instant decodes alone).
#pragma once

#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "video/video.h"

namespace dome::sequence {

struct VideoOptions {
  // x264's constant rate factor: 0 lossless .. 51; lower is better and larger. 28: an
  // atlas PSNR of about 29 dB, where 4:2:0 chroma already costs most (sequence tests),
  // at about 16 kB a frame for a 0.5 Mpx atlas.
  int crf = 28;
  // x264 preset: speed against size (ultrafast .. veryslow).
  std::string preset = "medium";
  // A keyframe every this many frames (1..600); 1 makes every instant independent.
  int keyframe_every = 1;
  // Encoder threads; 0: as many as the cores.
  int threads = 0;
  // Throws core::InputError naming the option out of range.
  void Check() const;
};

// One frame's packet: its frame index, whether it is a keyframe, its Annex B bytes.
using VideoPacket = video::H264Packet;

class VideoEncoder {
 public:
  VideoEncoder(int width, int height, double fps, const VideoOptions& options);
  ~VideoEncoder();
  VideoEncoder(const VideoEncoder&) = delete;
  VideoEncoder& operator=(const VideoEncoder&) = delete;

  // Encodes the next frame (CV_8UC3 BGR, at most width x height, placed at the top-left);
  // returns the packets that are ready (the encoder looks ahead a few frames).
  std::vector<VideoPacket> Encode(const cv::Mat& bgr);
  // The packets still held.
  std::vector<VideoPacket> Flush();
  // The codec string of RFC 6381 for WebCodecs / MSE ("avc1.PPCCLL" from the SPS),
  // known once the first packet is out; "" before.
  const std::string& codec() const { return codec_; }

 private:
  // Sends `frame` (empty: the end) and takes the packets that are ready.
  std::vector<VideoPacket> Drain(const cv::Mat& frame);
  struct State;
  std::unique_ptr<State> state_;
  std::string codec_;
  int64_t next_frame_ = 0;
};

// Decodes Annex B packets in order back to BGR frames (width x height).
class VideoDecoder {
 public:
  VideoDecoder();
  ~VideoDecoder();
  VideoDecoder(const VideoDecoder&) = delete;
  VideoDecoder& operator=(const VideoDecoder&) = delete;
  // The frames the packet completes (one for this stream's packets). Throws
  // core::InputError naming `where` when libavcodec refuses the packet.
  std::vector<cv::Mat> Decode(std::string_view packet, const std::string& where);
  std::vector<cv::Mat> Flush();

 private:
  // Sends `packet` (empty: the end) and takes the frames that are ready.
  std::vector<cv::Mat> Receive(std::string_view packet, const std::string& where);
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace dome::sequence
