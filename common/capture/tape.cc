#include "capture/tape.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/parallel_for.h"
#include "io/image_io.h"
#include "take/timecode.h"
#include "video/video.h"

namespace dome::capture {

void TapeLayout::Check() const {
  core::Require(vbi_field_lines >= 1 && vbi_field_lines <= 64, "vbi_field_lines",
                "must be in 1..64, got " + std::to_string(vbi_field_lines));
  core::Require(!vitc_field_lines.empty(), "vitc_field_lines", "names no line");
  for (int line : vitc_field_lines) {
    core::Require(line >= 0 && line < vbi_field_lines, "vitc_field_lines",
                  "line " + std::to_string(line) + " is outside the " +
                      std::to_string(vbi_field_lines) + " vertical-interval lines");
  }
}

VitcDecoderOptions TapeLayout::DecoderOptions() const {
  VitcDecoderOptions options;
  options.standard = standard;
  options.first_row = 0;
  options.last_row = VbiRows() - 1;
  return options;
}

cv::Mat ComposeTapeFrame(const cv::Mat& picture, VitcWord word, const TapeLayout& layout) {
  layout.Check();
  DOME_CHECK(picture.type() == CV_8UC1 && picture.rows % 2 == 0, "interlaced 8-bit grey picture");
  cv::Mat frame(picture.rows + layout.VbiRows(), picture.cols, CV_8UC1,
                cv::Scalar(layout.blanking_level));
  picture.copyTo(frame.rowRange(layout.VbiRows(), frame.rows));
  VitcLineOptions line;
  line.black_level = layout.blanking_level;
  for (int field = 0; field < 2; ++field) {
    word.field_mark = field == 1;
    const VitcBits bits = EncodeVitc(word, layout.standard);
    for (int l : layout.vitc_field_lines) {
      DOME_CHECK(l >= 0 && l < layout.vbi_field_lines, "VITC line outside the vertical interval");
      DrawVitcLine(bits, frame.ptr<uint8_t>(2 * l + field), frame.cols, line);
    }
  }
  return frame;
}

cv::Mat TapePicture(const cv::Mat& tape_frame, const TapeLayout& layout) {
  return tape_frame.rowRange(layout.VbiRows(), tape_frame.rows);
}

struct TapeWriter::Impl {
  std::unique_ptr<video::Sink> sink;
  std::filesystem::path path;
  cv::Size size;
};

TapeWriter::TapeWriter(const std::filesystem::path& path, cv::Size frame_size,
                       VideoStandard standard)
    : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  impl_->size = frame_size;
  impl_->sink = video::CreateFfv1(path.string(), frame_size, FramesPerSecond(standard),
                                  /*colour=*/false);
}

TapeWriter::~TapeWriter() = default;

void TapeWriter::Write(const cv::Mat& frame) {
  DOME_CHECK(frame.type() == CV_8UC1 && frame.size() == impl_->size, "tape frame size and type");
  impl_->sink->Write(frame);
}

void TapeWriter::Close() { impl_->sink->Close(); }

int WriteTakeTapes(const std::filesystem::path& take_dir, const TapeLayout& layout, int threads) {
  namespace fs = std::filesystem;
  const fs::path tape_dir = take_dir / "tape";
  core::Require(fs::is_directory(tape_dir), tape_dir.string(),
                "no tape/ folder of interlaced frames");
  std::vector<std::pair<take::Timecode, fs::path>> instants;
  std::vector<std::string> cameras;
  for (const auto& entry : fs::directory_iterator(tape_dir)) {
    if (!entry.is_directory()) continue;
    const auto tc = take::ParseInstantName(entry.path().filename().string());
    if (tc) instants.emplace_back(*tc, entry.path());
  }
  std::sort(instants.begin(), instants.end());
  core::Require(!instants.empty(), tape_dir.string(), "no instant folders HH-MM-SS-FF");
  for (const auto& entry : fs::directory_iterator(instants.front().second)) {
    if (entry.path().extension() == ".png") cameras.push_back(entry.path().stem().string());
  }
  std::sort(cameras.begin(), cameras.end());
  core::ParallelFor(0, static_cast<int64_t>(cameras.size()), threads, [&](int64_t b, int64_t e) {
    for (int64_t c = b; c < e; ++c) {
      std::unique_ptr<TapeWriter> writer;
      for (const auto& [tc, dir] : instants) {
        const cv::Mat picture = io::ReadImage(dir / (cameras[c] + ".png"), io::ImageMode::kGray8);
        VitcWord word;
        word.time = tc;
        const cv::Mat frame = ComposeTapeFrame(picture, word, layout);
        if (!writer)
          writer = std::make_unique<TapeWriter>(tape_dir / (cameras[c] + ".avi"), frame.size(),
                                                layout.standard);
        writer->Write(frame);
      }
      writer->Close();
    }
  });
  return static_cast<int>(cameras.size());
}

std::vector<cv::Mat> ReadTapeFrames(const std::filesystem::path& path) {
  core::Require(std::filesystem::is_regular_file(path), path.string(), "no such tape file");
  const std::unique_ptr<video::Source> source = video::OpenFile(path.string());
  std::vector<cv::Mat> frames;
  cv::Mat frame;
  while (source->Read(&frame)) {
    cv::Mat grey;
    if (frame.channels() == 3) {
      cv::extractChannel(frame, grey, 0);  // grey video comes back as equal B, G, R
    } else {
      grey = frame.clone();
    }
    frames.push_back(grey);
  }
  core::Require(!frames.empty(), path.string(), "the video holds no frames");
  return frames;
}

}  // namespace dome::capture
