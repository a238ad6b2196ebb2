// Fields of an interlaced frame, and the take image the seed made from them (§4.2):
// split the 490 x 640 frame into two 245 x 640 fields exposed 1/60 s apart, keep the
// first in time, average column pairs to 245 x 320:
//   image(y, x) = (field(y, 2x) + field(y, 2x + 1) + 1) / 2   (integer division)
// the same rule `dome synth` renders its frames/ with (synth/render.h).
#pragma once

#include <opencv2/core.hpp>

#include "capture/tape.h"
#include "capture/vitc.h"

namespace dome::capture {

struct FieldOptions {
  // Which rows of the frame were exposed first: true = the even rows (0, 2, ...), the
  // field whose VITC carries field mark 0 on our tapes.
  bool upper_field_first = true;
  // Check the first-in-time field's VITC field mark is 0 (it names the first field).
  bool check_field_mark = true;
  // (Two switches: no value is out of range, so there is nothing to Check().)
};

// Rows r with r % 2 == parity, as a new image.
cv::Mat ExtractField(const cv::Mat& frame, int parity);
// Column pairs averaged, rounding halves up (width must be even).
cv::Mat AverageColumnPairs(const cv::Mat& field);

// The take image of a tape frame: its first field's picture, column pairs averaged.
// With check_field_mark, VITC is read from that field's vertical-interval lines and
// core::InputError (naming `where`) is thrown when the field mark says it is the
// second field or no word can be read there.
cv::Mat TakeImage(const cv::Mat& tape_frame, const TapeLayout& layout, const FieldOptions& options,
                  const std::string& where);

}  // namespace dome::capture
