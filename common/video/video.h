// Video for the parts of dome that read or write it: files and capture devices frame by
// frame (OpenCV's videoio: FFmpeg for files, V4L2 for devices) for tapes, digitizers and
// `dome import video`; H.264 (libavcodec with libx264, libswscale) for the atlases of
// `dome export`'s 4D file.
//
// Why a module: Debian's OpenCV videoio and libavcodec bring GStreamer, FFmpeg's codecs
// and demuxers and OpenCV's image codecs, about 200 shared libraries that a program loads
// and relocates when it starts, whether or not it touches a video (0.2 s of every `dome`
// command; the dome programs otherwise load under 60). So they are linked only into a
// small module,
// lib/dome/libdome_video.so beside the programs (bin/../lib/dome, in the build tree and
// installed), which the first call here loads (dlopen) and which stays loaded.
// DOME_VIDEO_MODULE names another file.
//
// Frames are cv::Mat as OpenCV's videoio gives them: 8-bit BGR for colour and, for most
// codecs, grey video as equal B, G, R.
#pragma once

#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <vector>

namespace dome::video {

// Frames of one file or device, in order.
class Source {
 public:
  virtual ~Source() = default;
  // The next frame; false at the end or on a frame that does not decode.
  virtual bool Read(cv::Mat* frame) = 0;
  // Steps over the next frame without converting it; false as Read.
  virtual bool Skip() = 0;
  // What the container says: frames a second, frame count (<= 0: it does not say), and
  // the frames' size in pixels.
  virtual double fps() const = 0;
  virtual double frame_count() const = 0;
  virtual cv::Size size() const = 0;
};

// A lossless FFV1 video being written (AVI: its bytes are a function of the frames alone).
class Sink {
 public:
  virtual ~Sink() = default;
  // A frame of the size and kind given at opening (8-bit grey or BGR).
  virtual void Write(const cv::Mat& frame) = 0;
  // Finishes the file; writing after this is a programmer error.
  virtual void Close() = 0;
};

// Opens a video file (FFmpeg). Throws core::InputError naming `path` when it cannot be
// opened, or naming the module when video support is not installed.
std::unique_ptr<Source> OpenFile(const std::string& path);

// Opens a V4L2 capture device ("/dev/video0"). Throws as OpenFile.
std::unique_ptr<Source> OpenDevice(const std::string& device);

// Creates `path` as an FFV1 AVI of `size` frames at `fps`, grey (8-bit, 1 channel) or
// colour (BGR). Throws core::InputError naming `path` when it cannot be written.
std::unique_ptr<Sink> CreateFfv1(const std::string& path, cv::Size size, double fps, bool colour);

// H.264 in Annex B packets (start codes; SPS/PPS before every keyframe), no B-frames, so
// decode order is display order. 4:2:0 YUV with BT.601 limited-range coefficients on both
// sides of the conversion (sequence/video.h says why).
struct H264Settings {
  int width = 0, height = 0;  // even, pixels
  double fps = 30;
  int crf = 28;                   // x264's constant rate factor, 0..51
  std::string preset = "medium";  // x264's preset
  int keyframe_every = 1;         // frames
  int threads = 0;                // 0: as many as the cores
};

struct H264Packet {
  int64_t frame = 0;  // index of the frame it holds
  bool keyframe = false;
  std::string bytes;  // Annex B
};

class H264Encoder {
 public:
  virtual ~H264Encoder() = default;
  // Encodes `bgr` (CV_8UC3, exactly width x height) as frame `index`, or with an empty
  // `bgr` flushes; appends the packets that are ready. false, saying why, when libx264
  // refuses.
  virtual bool Encode(const cv::Mat& bgr, int64_t index, std::vector<H264Packet>* out,
                      std::string* error) = 0;
};

class H264Decoder {
 public:
  virtual ~H264Decoder() = default;
  // Decodes one packet, or with an empty one flushes; appends the BGR frames it
  // completes. false, saying why, when the packet or a frame does not decode.
  virtual bool Decode(std::string_view packet, std::vector<cv::Mat>* out, std::string* error) = 0;
};

// Throw core::InputError naming `where` when libavcodec has no such coder or refuses the
// settings.
std::unique_ptr<H264Encoder> CreateH264Encoder(const H264Settings& settings,
                                               const std::string& where);
std::unique_ptr<H264Decoder> CreateH264Decoder(const std::string& where);

// The interface between this library and the module (video_module.cc): one table of
// functions, found by the C symbol dome_video_backend. Each returns nullptr and says why
// in *error on failure. kAbi changes with the table, so a stale module is named, not run.
struct Backend {
  static constexpr int kAbi = 2;
  int abi = kAbi;
  Source* (*open_file)(const std::string& path, std::string* error);
  Source* (*open_device)(const std::string& device, std::string* error);
  Sink* (*create_ffv1)(const std::string& path, cv::Size size, double fps, bool colour,
                       std::string* error);
  H264Encoder* (*create_h264_encoder)(const H264Settings& settings, std::string* error);
  H264Decoder* (*create_h264_decoder)(std::string* error);
};

}  // namespace dome::video
