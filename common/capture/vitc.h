// Vertical Interval Time Code (SMPTE 12M), as the seed's cameras stamped their tapes
// (seed §2.1): a 90-bit word drawn on a scan line of the vertical interval.
//
// The word, bit 0 first (leftmost on the line), is nine groups of ten bits: a sync
// pair "1 0" then eight data bits. The 72 data bits carry, least significant bit
// first, what LTC bits 0..63 carry plus an 8-bit CRC:
//   data byte 0: frame units (4)      | user bits group 1 (4)
//   data byte 1: frame tens (2), drop-frame flag, colour-frame flag | group 2
//   data byte 2: seconds units        | group 3
//   data byte 3: seconds tens (3), flag A | group 4
//   data byte 4: minutes units        | group 5
//   data byte 5: minutes tens (3), flag B | group 6
//   data byte 6: hours units          | group 7
//   data byte 7: hours tens (2), flag C, flag D | group 8
//   data byte 8: CRC
// Flags A..D: on 525/60 A = field mark, B = BGF0, C = BGF1, D = BGF2; on 625/50
// A = BGF0, B = BGF2, C = BGF1, D = field mark. The field mark is 0 in the first
// field of a frame and 1 in the second.
// CRC (generator x^8 + 1): for each residue r of the bit index modulo 8, the XOR of
// the word's 90 bits whose index is r modulo 8 is zero; so CRC bit 82 + k is the XOR
// of bits 0..81 whose index equals 82 + k modulo 8. Any single wrong bit breaks it.
//
// On the line a "1" is white (about 80 IRE) and a "0" black (blanking). 525/60 sends
// 115 bit cells per line period and 625/50 116; of a digitized active line that is
// about 96 cells, so the default cell is width / 96 pixels (what ffmpeg's readvitc
// expects: ten-bit groups of width * 5 / 48 pixels).
#pragma once

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "capture/timecode_count.h"
#include "take/timecode.h"

namespace dome::capture {

inline constexpr int kVitcBits = 90;
using VitcBits = std::array<uint8_t, kVitcBits>;  // 0 or 1, bit 0 first

struct VitcWord {
  take::Timecode time;
  bool drop_frame = false;     // the labels follow the drop-frame rule
  bool colour_frame = false;   // colour framing locked to the time code
  bool field_mark = false;     // false in the first field, true in the second
  int binary_group_flags = 0;  // BGF0..BGF2 in bits 0..2
  uint32_t user_bits = 0;      // binary groups 1..8, group 1 in the low nibble

  bool operator==(const VitcWord&) const = default;
};

// The 90 bits of `word` on `standard` (which decides where the flags go), CRC
// included. DOME_CHECKs that the time fields fit their BCD digits.
VitcBits EncodeVitc(const VitcWord& word, VideoStandard standard);

// The word in `bits`, or nullopt unless every sync pair is "1 0", the CRC holds and
// every BCD digit is a decimal digit within its field's range.
std::optional<VitcWord> DecodeVitcBits(const VitcBits& bits, VideoStandard standard);

// The CRC byte for bits 0..81 (bit k of the result goes to word bit 82 + k).
uint8_t VitcCrc(const VitcBits& bits);

struct VitcLineOptions {
  double cell_px = 0.0;       // width of one bit cell, pixels; 0 = width / 96
  double start_px = -1.0;     // left edge of bit 0, pixels; < 0 = two cells from the left
  uint8_t black_level = 16;   // grey level of a 0 (blanking), 8-bit
  uint8_t white_level = 192;  // grey level of a 1 (about 80 IRE), 8-bit

  // Throws core::InputError naming the first option out of range.
  void Check() const;
};

// Draws the word on one 8-bit grey line of `width` pixels: each pixel is the level of
// the bits under it weighted by how much of the pixel each covers; pixels outside the
// word are at the black level.
void DrawVitcLine(const VitcBits& bits, uint8_t* line, int width,
                  const VitcLineOptions& options = {});

struct VitcDecoderOptions {
  VideoStandard standard = VideoStandard::k525NonDrop;
  double nominal_cell_fraction = 1.0 / 96.0;  // expected bit cell, as a fraction of the width
  double scale_tolerance = 0.12;  // accepted relative deviation of the cell from nominal
  int min_swing = 24;             // least white-minus-black difference, grey levels
  int first_row = 0;              // rows of a frame searched: [first_row, last_row]
  int last_row = 44;              // inclusive; clamped to the frame

  // Throws core::InputError naming the first option out of range.
  void Check() const;
};

// One word read from a frame.
struct VitcRead {
  VitcWord word;
  int row = 0;            // frame row it was read on
  double cell_px = 0.0;   // measured bit cell, pixels
  double start_px = 0.0;  // measured left edge of bit 0, pixels
};

// Reads VITC from scan lines: finds the nine sync edges (any black and white levels,
// gain, offset and a horizontal scale within the tolerance), samples each bit cell's
// middle half, and accepts a word only if its syncs, CRC and digits check. Never
// returns a word that failed its CRC.
class VitcDecoder {
 public:
  explicit VitcDecoder(const VitcDecoderOptions& options = {});

  std::optional<VitcRead> ReadLine(const uint8_t* line, int width) const;
  // Every row of the search range that carries a valid word, top to bottom.
  std::vector<VitcRead> ReadAll(const cv::Mat& frame) const;
  // The first row of the search range that carries a valid word.
  std::optional<VitcRead> ReadFirst(const cv::Mat& frame) const;

  const VitcDecoderOptions& options() const { return options_; }

 private:
  VitcDecoderOptions options_;
};

}  // namespace dome::capture
