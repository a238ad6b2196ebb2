// Test tapes: interlaced frames whose picture names the frame, stamped with VITC.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "capture/tape.h"
#include "capture/timecode_count.h"

namespace dome::capture::test_tapes {

// The interlaced picture of tape frame `n` (frame number): every pixel a function of
// n, row and column, so any mix-up of frames or fields shows.
inline cv::Mat TestPicture(int64_t n, int rows = 40, int cols = 384) {
  cv::Mat picture(rows, cols, CV_8UC1);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c)
      picture.at<uint8_t>(r, c) = static_cast<uint8_t>((n * 37 + r * 5 + c * 3) % 251);
  }
  return picture;
}

// The take image the capture must produce for frame n: first (even) field, column
// pairs averaged.
inline cv::Mat ExpectedTakeImage(int64_t n) {
  const cv::Mat p = TestPicture(n);
  cv::Mat image(p.rows / 2, p.cols / 2, CV_8UC1);
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      image.at<uint8_t>(y, x) = static_cast<uint8_t>(
          (p.at<uint8_t>(2 * y, 2 * x) + p.at<uint8_t>(2 * y, 2 * x + 1) + 1) / 2);
    }
  }
  return image;
}

// Tape frames for frame numbers `numbers`, in that order (repeats and reversals allowed);
// frames listed in `no_vitc` get a blank vertical interval.
inline std::vector<cv::Mat> MakeTape(const std::vector<int64_t>& numbers, const TapeLayout& layout,
                                     const std::vector<int64_t>& no_vitc = {}) {
  std::vector<cv::Mat> frames;
  for (int64_t n : numbers) {
    VitcWord w;
    w.time = LabelOf(n, layout.standard);
    w.drop_frame = layout.standard == VideoStandard::k525DropFrame;
    cv::Mat frame = ComposeTapeFrame(TestPicture(n), w, layout);
    for (int64_t blank : no_vitc) {
      if (blank == n) frame.rowRange(0, layout.VbiRows()).setTo(layout.blanking_level);
    }
    frames.push_back(frame);
  }
  return frames;
}

inline std::vector<int64_t> Consecutive(int64_t first, int count) {
  std::vector<int64_t> v;
  for (int i = 0; i < count; ++i) v.push_back(first + i);
  return v;
}

}  // namespace dome::capture::test_tapes
