// dome's video module (lib/dome/libdome_video.so): OpenCV's videoio and libavcodec
// behind video.h's Backend. It links those and nothing of dome, so it is small and loads
// only when a video is opened (see video.h).
#include <opencv2/videoio.hpp>

#include "video/h264_module.h"
#include "video/video.h"

namespace dome::video {
namespace {

class CvSource final : public Source {
 public:
  explicit CvSource(cv::VideoCapture capture) : capture_(std::move(capture)) {}
  bool Read(cv::Mat* frame) override { return capture_.read(*frame) && !frame->empty(); }
  bool Skip() override { return capture_.grab(); }
  double fps() const override { return capture_.get(cv::CAP_PROP_FPS); }
  double frame_count() const override { return capture_.get(cv::CAP_PROP_FRAME_COUNT); }
  cv::Size size() const override {
    return {int(capture_.get(cv::CAP_PROP_FRAME_WIDTH)),
            int(capture_.get(cv::CAP_PROP_FRAME_HEIGHT))};
  }

 private:
  cv::VideoCapture capture_;
};

class CvSink final : public Sink {
 public:
  explicit CvSink(cv::VideoWriter writer) : writer_(std::move(writer)) {}
  void Write(const cv::Mat& frame) override { writer_.write(frame); }
  void Close() override { writer_.release(); }

 private:
  cv::VideoWriter writer_;
};

Source* Open(const std::string& target, int api, const char* what, std::string* error) {
  try {
    cv::VideoCapture capture(target, api);
    if (capture.isOpened()) return new CvSource(std::move(capture));
    *error = what;
  } catch (const cv::Exception& e) {
    *error = std::string(what) + ": " + e.what();
  }
  return nullptr;
}

Source* OpenFile(const std::string& path, std::string* error) {
  return Open(path, cv::CAP_FFMPEG,
              "cannot be opened as a video (not a video file, or a codec "
              "FFmpeg does not decode)",
              error);
}

Source* OpenDevice(const std::string& device, std::string* error) {
  return Open(device, cv::CAP_V4L2, "cannot open the video device (V4L2)", error);
}

Sink* CreateFfv1(const std::string& path, cv::Size size, double fps, bool colour,
                 std::string* error) {
  try {
    cv::VideoWriter writer(path, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('F', 'F', 'V', '1'), fps,
                           size, colour);
    if (writer.isOpened()) return new CvSink(std::move(writer));
    *error = "cannot open for writing an FFV1 video (OpenCV with FFmpeg, writable folder)";
  } catch (const cv::Exception& e) {
    *error = std::string("cannot write an FFV1 video: ") + e.what();
  }
  return nullptr;
}

const Backend kBackend{Backend::kAbi, OpenFile,       OpenDevice,
                       CreateFfv1,    NewH264Encoder, NewH264Decoder};

}  // namespace
}  // namespace dome::video

extern "C" __attribute__((visibility("default"))) const dome::video::Backend* dome_video_backend() {
  return &dome::video::kBackend;
}
