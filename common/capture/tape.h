// Taped video frames and tape files.
//
// A tape frame is what a digitizer delivers for one interlaced video frame when it
// keeps the vertical interval: 8-bit grey, `width` x (2 * vbi_field_lines +
// picture_rows). Row r belongs to field r % 2 (0 = the field sent first, "upper"),
// field line r / 2. Each field begins with `vbi_field_lines` vertical-interval lines
// (525/60: lines 10..21 of the field) at the blanking level; VITC is drawn on field
// lines `vitc_field_lines` of both fields (525/60: lines 14 and 16, and 277 and 279,
// as SMPTE RP 164 recommends), with field mark 0 in field 0 and 1 in field 1. The
// picture follows: its row p is frame row 2 * vbi_field_lines + p.
//
// A tape file is a lossless video (FFV1 in AVI, 8-bit grey; AVI because its bytes are a
// function of the frames alone) of tape frames at the standard's frame rate. A synthetic
// take's tapes are TAKE/tape/<camera>.avi (WriteTakeTapes).
#pragma once

#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "capture/timecode_count.h"
#include "capture/vitc.h"

namespace dome::capture {

struct TapeLayout {
  VideoStandard standard = VideoStandard::k525NonDrop;
  int vbi_field_lines = 12;  // vertical-interval lines kept above each field's picture
  std::vector<int> vitc_field_lines{4, 6};  // field lines (0-based within the VBI) carrying VITC
  uint8_t blanking_level = 16;              // grey level of the vertical interval

  int VbiRows() const { return 2 * vbi_field_lines; }
  // Throws core::InputError naming the first field out of range ("vitc_field_lines").
  void Check() const;
  // Decoder options that search exactly this layout's vertical interval.
  VitcDecoderOptions DecoderOptions() const;
};

// The tape frame of interlaced `picture` (8-bit grey, rows interleaved by field) with
// `word`'s time code in both fields (field_mark set per field).
cv::Mat ComposeTapeFrame(const cv::Mat& picture, VitcWord word, const TapeLayout& layout);

// The picture rows of a tape frame (a view, not a copy).
cv::Mat TapePicture(const cv::Mat& tape_frame, const TapeLayout& layout);

// Writes tape frames into a lossless video file. Throws core::InputError naming the
// file when it cannot be opened for writing.
class TapeWriter {
 public:
  TapeWriter(const std::filesystem::path& path, cv::Size frame_size, VideoStandard standard);
  ~TapeWriter();
  TapeWriter(const TapeWriter&) = delete;
  TapeWriter& operator=(const TapeWriter&) = delete;

  void Write(const cv::Mat& frame);  // 8-bit grey of frame_size
  void Close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Writes TAKE/tape/<camera>.avi for every camera with frames TAKE/tape/<instant>/<camera>.png
// (`dome synth`'s interlaced frames): one tape frame per instant, instants in order, each
// stamped with its instant's time code. Cameras in parallel on `threads` (0 = all).
// Returns the number of tapes written. Throws core::InputError naming the take or file.
int WriteTakeTapes(const std::filesystem::path& take_dir, const TapeLayout& layout, int threads);

// Every frame of a tape video, 8-bit grey. Throws core::InputError naming the file
// when it cannot be opened or holds no frames.
std::vector<cv::Mat> ReadTapeFrames(const std::filesystem::path& path);

}  // namespace dome::capture
