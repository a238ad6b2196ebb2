#include "capture/fields.h"

#include "core/error.h"

namespace dome::capture {

cv::Mat ExtractField(const cv::Mat& frame, int parity) {
  DOME_CHECK(frame.type() == CV_8UC1 && (parity == 0 || parity == 1),
             "8-bit grey frame, parity 0/1");
  cv::Mat field((frame.rows - parity + 1) / 2, frame.cols, CV_8UC1);
  for (int y = 0; y < field.rows; ++y) frame.row(2 * y + parity).copyTo(field.row(y));
  return field;
}

cv::Mat AverageColumnPairs(const cv::Mat& field) {
  DOME_CHECK(field.type() == CV_8UC1 && field.cols % 2 == 0, "8-bit grey field of even width");
  cv::Mat image(field.rows, field.cols / 2, CV_8UC1);
  for (int y = 0; y < field.rows; ++y) {
    const uint8_t* in = field.ptr<uint8_t>(y);
    uint8_t* out = image.ptr<uint8_t>(y);
    for (int x = 0; x < image.cols; ++x)
      out[x] = static_cast<uint8_t>((in[2 * x] + in[2 * x + 1] + 1) / 2);
  }
  return image;
}

cv::Mat TakeImage(const cv::Mat& tape_frame, const TapeLayout& layout, const FieldOptions& options,
                  const std::string& where) {
  const int parity = options.upper_field_first ? 0 : 1;
  if (options.check_field_mark) {
    VitcDecoder decoder(layout.DecoderOptions());
    bool read_any = false;
    for (int l : layout.vitc_field_lines) {
      const int row = 2 * l + parity;
      if (row >= tape_frame.rows) continue;
      const auto read = decoder.ReadLine(tape_frame.ptr<uint8_t>(row), tape_frame.cols);
      if (!read) continue;
      read_any = true;
      core::Require(!read->word.field_mark, where,
                    "the field kept as first in time (" +
                        std::string(parity == 0 ? "even" : "odd") +
                        " rows) carries VITC field mark 1, the second field's; the field order "
                        "option does not match the tape");
    }
    core::Require(read_any, where,
                  "no VITC on the first field's vertical-interval lines, so its field mark "
                  "cannot be checked");
  }
  const cv::Mat picture = TapePicture(tape_frame, layout);
  return AverageColumnPairs(ExtractField(picture, parity));
}

}  // namespace dome::capture
