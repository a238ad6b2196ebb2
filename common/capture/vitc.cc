#include "capture/vitc.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace dome::capture {
namespace {

// Word index of LTC-style data bit b (0..71): past b / 8 sync pairs and its own.
constexpr int DataBit(int b) { return (b / 8) * 10 + 2 + b % 8; }

// Positions (data-bit numbers) of flags A..D and which meaning each has.
constexpr int kFlagA = 27, kFlagB = 43, kFlagC = 58, kFlagD = 59;

struct FlagMap {
  int field_mark, bgf0, bgf1, bgf2;
};
FlagMap Flags(VideoStandard standard) {
  if (Is525(standard)) return {kFlagA, kFlagB, kFlagC, kFlagD};
  return {kFlagD, kFlagA, kFlagC, kFlagB};
}

void PutBits(VitcBits& bits, int first_data_bit, int count, int value) {
  for (int i = 0; i < count; ++i) bits[DataBit(first_data_bit + i)] = (value >> i) & 1;
}
int GetBits(const VitcBits& bits, int first_data_bit, int count) {
  int value = 0;
  for (int i = 0; i < count; ++i) value |= bits[DataBit(first_data_bit + i)] << i;
  return value;
}

}  // namespace

uint8_t VitcCrc(const VitcBits& bits) {
  uint8_t crc = 0;
  for (int j = 0; j < 82; ++j) {
    if (bits[j]) crc ^= static_cast<uint8_t>(1u << ((j - 82 + 88) % 8));
  }
  return crc;
}

VitcBits EncodeVitc(const VitcWord& word, VideoStandard standard) {
  const take::Timecode& t = word.time;
  DOME_CHECK(t.frames >= 0 && t.frames < 40 && t.seconds >= 0 && t.seconds < 80 && t.minutes >= 0 &&
                 t.minutes < 80 && t.hours >= 0 && t.hours < 40,
             "time code fields do not fit VITC's digits");
  VitcBits bits{};
  for (int g = 0; g < 9; ++g) bits[10 * g] = 1;  // sync pairs "1 0"
  PutBits(bits, 0, 4, t.frames % 10);
  PutBits(bits, 8, 2, t.frames / 10);
  PutBits(bits, 10, 1, word.drop_frame);
  PutBits(bits, 11, 1, word.colour_frame);
  PutBits(bits, 16, 4, t.seconds % 10);
  PutBits(bits, 24, 3, t.seconds / 10);
  PutBits(bits, 32, 4, t.minutes % 10);
  PutBits(bits, 40, 3, t.minutes / 10);
  PutBits(bits, 48, 4, t.hours % 10);
  PutBits(bits, 56, 2, t.hours / 10);
  const FlagMap f = Flags(standard);
  PutBits(bits, f.field_mark, 1, word.field_mark);
  PutBits(bits, f.bgf0, 1, word.binary_group_flags & 1);
  PutBits(bits, f.bgf1, 1, (word.binary_group_flags >> 1) & 1);
  PutBits(bits, f.bgf2, 1, (word.binary_group_flags >> 2) & 1);
  for (int g = 0; g < 8; ++g)
    PutBits(bits, 8 * g + 4, 4, static_cast<int>((word.user_bits >> (4 * g)) & 0xF));
  const uint8_t crc = VitcCrc(bits);
  for (int k = 0; k < 8; ++k) bits[82 + k] = (crc >> k) & 1;
  return bits;
}

std::optional<VitcWord> DecodeVitcBits(const VitcBits& bits, VideoStandard standard) {
  for (int g = 0; g < 9; ++g) {
    if (bits[10 * g] != 1 || bits[10 * g + 1] != 0) return std::nullopt;
  }
  const uint8_t crc = VitcCrc(bits);
  for (int k = 0; k < 8; ++k) {
    if (bits[82 + k] != ((crc >> k) & 1)) return std::nullopt;
  }
  const int fu = GetBits(bits, 0, 4), ft = GetBits(bits, 8, 2);
  const int su = GetBits(bits, 16, 4), st = GetBits(bits, 24, 3);
  const int mu = GetBits(bits, 32, 4), mt = GetBits(bits, 40, 3);
  const int hu = GetBits(bits, 48, 4), ht = GetBits(bits, 56, 2);
  if (fu > 9 || su > 9 || mu > 9 || hu > 9) return std::nullopt;
  VitcWord word;
  word.time = {ht * 10 + hu, mt * 10 + mu, st * 10 + su, ft * 10 + fu};
  if (word.time.hours > 23 || word.time.minutes > 59 || word.time.seconds > 59 ||
      word.time.frames >= LabelsPerSecond(standard)) {
    return std::nullopt;
  }
  word.drop_frame = GetBits(bits, 10, 1);
  word.colour_frame = GetBits(bits, 11, 1);
  const FlagMap f = Flags(standard);
  word.field_mark = GetBits(bits, f.field_mark, 1);
  word.binary_group_flags =
      GetBits(bits, f.bgf0, 1) | (GetBits(bits, f.bgf1, 1) << 1) | (GetBits(bits, f.bgf2, 1) << 2);
  for (int g = 0; g < 8; ++g)
    word.user_bits |= static_cast<uint32_t>(GetBits(bits, 8 * g + 4, 4)) << (4 * g);
  return word;
}

void VitcLineOptions::Check() const {
  core::Require(std::isfinite(cell_px) && cell_px >= 0, "cell_px", "must be >= 0 (0: width / 96)");
  core::Require(std::isfinite(start_px), "start_px", "must be finite");
  core::Require(white_level > black_level, "white_level",
                "must be above black_level (" + std::to_string(black_level) + ")");
}

void VitcDecoderOptions::Check() const {
  core::Require(nominal_cell_fraction > 0 && nominal_cell_fraction < 0.1, "nominal_cell_fraction",
                "must be in (0, 0.1), got " + std::to_string(nominal_cell_fraction));
  core::Require(scale_tolerance > 0 && scale_tolerance < 1, "scale_tolerance",
                "must be in (0, 1), got " + std::to_string(scale_tolerance));
  core::Require(min_swing >= 1 && min_swing <= 255, "min_swing", "must be in 1..255 grey levels");
  core::Require(first_row >= 0 && first_row <= last_row, "first_row",
                "must be in 0..last_row (" + std::to_string(last_row) + ")");
}

void DrawVitcLine(const VitcBits& bits, uint8_t* line, int width, const VitcLineOptions& options) {
  options.Check();
  const double cell = options.cell_px > 0.0 ? options.cell_px : width / 96.0;
  const double start = options.start_px >= 0.0 ? options.start_px : 2.0 * cell;
  const double black = options.black_level, white = options.white_level;
  for (int x = 0; x < width; ++x) {
    // Fraction of pixel [x, x + 1) covered by "1" cells.
    double ones = 0.0;
    const int k0 = std::max(0, static_cast<int>(std::floor((x - start) / cell)));
    const int k1 = std::min(kVitcBits - 1, static_cast<int>(std::floor((x + 1 - start) / cell)));
    for (int k = k0; k <= k1; ++k) {
      if (!bits[k]) continue;
      const double a = std::max<double>(x, start + k * cell);
      const double b = std::min<double>(x + 1, start + (k + 1) * cell);
      if (b > a) ones += b - a;
    }
    line[x] = static_cast<uint8_t>(std::lround(black + (white - black) * ones));
  }
}

VitcDecoder::VitcDecoder(const VitcDecoderOptions& options) : options_(options) { options.Check(); }

std::optional<VitcRead> VitcDecoder::ReadLine(const uint8_t* line, int width) const {
  if (width < 96) return std::nullopt;
  // Light smoothing against noise; levels from the extremes of the smoothed line.
  std::vector<float> s(width);
  s[0] = line[0];
  s[width - 1] = line[width - 1];
  for (int x = 1; x + 1 < width; ++x)
    s[x] = 0.25f * line[x - 1] + 0.5f * line[x] + 0.25f * line[x + 1];
  const auto [lo_it, hi_it] = std::minmax_element(s.begin(), s.end());
  const float lo = *lo_it, hi = *hi_it;
  if (hi - lo < options_.min_swing) return std::nullopt;
  const float mid = 0.5f * (lo + hi), hyst = 0.15f * (hi - lo);

  // Falling edges through the middle level, with hysteresis; sub-pixel positions in
  // line coordinates (pixel x covers [x, x + 1), so its sample sits at x + 0.5).
  std::vector<double> falls;
  bool high = s[0] > mid;
  int last_above = high ? 0 : -1;
  for (int x = 1; x < width; ++x) {
    if (s[x] >= mid) last_above = x;
    if (high && s[x] < mid - hyst && last_above >= 0 && last_above + 1 < width) {
      const int a = last_above;
      const double t = (s[a] - mid) / std::max(1e-3f, s[a] - s[a + 1]);
      falls.push_back(a + 0.5 + std::clamp(t, 0.0, 1.0));
      high = false;
    } else if (!high && s[x] > mid + hyst) {
      high = true;
    }
  }
  if (falls.size() < 9) return std::nullopt;

  const double nominal = options_.nominal_cell_fraction * width;
  const double cell_min = nominal * (1.0 - options_.scale_tolerance);
  const double cell_max = nominal * (1.0 + options_.scale_tolerance);
  auto near_edge = [&](double x, double tol) -> double {
    const auto it = std::lower_bound(falls.begin(), falls.end(), x - tol);
    if (it != falls.end() && *it <= x + tol) return *it;
    return -1.0;
  };
  // Each group's sync pair gives a falling edge at the start of its bit 10 g + 1.
  for (size_t a = 0; a < falls.size(); ++a) {
    for (size_t b = a + 8; b < falls.size(); ++b) {
      const double cell = (falls[b] - falls[a]) / 80.0;
      if (cell < cell_min) continue;
      if (cell > cell_max) break;
      std::array<double, 9> edge{};
      edge[0] = falls[a];
      edge[8] = falls[b];
      bool all = true;
      for (int g = 1; g < 8 && all; ++g) {
        edge[g] = near_edge(falls[a] + 10.0 * g * cell, 0.35 * cell);
        all = edge[g] >= 0.0;
      }
      if (!all) continue;
      // Least-squares line through the nine edges: edge_g = e0 + 10 g c.
      double sg = 0, se = 0, sgg = 0, sge = 0;
      for (int g = 0; g < 9; ++g) {
        sg += g, se += edge[g], sgg += g * g, sge += g * edge[g];
      }
      const double slope = (9 * sge - sg * se) / (9 * sgg - sg * sg);
      const double e0 = (se - slope * sg) / 9.0;
      const double c = slope / 10.0;
      const double start = e0 - c;  // left edge of bit 0
      // Mean level over the middle half of each cell.
      std::array<double, kVitcBits> level{};
      bool inside = true;
      for (int k = 0; k < kVitcBits && inside; ++k) {
        const double from = start + (k + 0.25) * c, to = start + (k + 0.75) * c;
        int x0 = static_cast<int>(std::floor(from)), x1 = static_cast<int>(std::ceil(to)) - 1;
        if (x1 < x0) x1 = x0;
        if (x0 < 0 || x1 >= width) {
          inside = false;
          break;
        }
        double sum = 0.0;
        for (int x = x0; x <= x1; ++x) sum += line[x];
        level[k] = sum / (x1 - x0 + 1);
      }
      if (!inside) continue;
      double one = 0.0, zero = 0.0;
      for (int g = 0; g < 9; ++g) one += level[10 * g], zero += level[10 * g + 1];
      const double threshold = 0.5 * (one + zero) / 9.0;
      VitcBits bits{};
      for (int k = 0; k < kVitcBits; ++k) bits[k] = level[k] > threshold ? 1 : 0;
      const auto word = DecodeVitcBits(bits, options_.standard);
      if (!word) continue;
      VitcRead read;
      read.word = *word;
      read.cell_px = c;
      read.start_px = start;
      return read;
    }
  }
  return std::nullopt;
}

std::vector<VitcRead> VitcDecoder::ReadAll(const cv::Mat& frame) const {
  DOME_CHECK(frame.type() == CV_8UC1, "VITC is read from 8-bit grey frames");
  std::vector<VitcRead> reads;
  const int last = std::min(options_.last_row, frame.rows - 1);
  for (int r = std::max(0, options_.first_row); r <= last; ++r) {
    auto read = ReadLine(frame.ptr<uint8_t>(r), frame.cols);
    if (read) {
      read->row = r;
      reads.push_back(*read);
    }
  }
  return reads;
}

std::optional<VitcRead> VitcDecoder::ReadFirst(const cv::Mat& frame) const {
  DOME_CHECK(frame.type() == CV_8UC1, "VITC is read from 8-bit grey frames");
  const int last = std::min(options_.last_row, frame.rows - 1);
  for (int r = std::max(0, options_.first_row); r <= last; ++r) {
    auto read = ReadLine(frame.ptr<uint8_t>(r), frame.cols);
    if (read) {
      read->row = r;
      return read;
    }
  }
  return std::nullopt;
}

}  // namespace dome::capture
