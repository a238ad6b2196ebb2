#include "capture/timecode_count.h"

#include <cstdio>

#include "core/error.h"

namespace dome::capture {
namespace {

constexpr int64_t kDropFramesPerTenMinutes = 17982;  // 10 * 60 * 30 - 9 * 2
constexpr int64_t kDropFramesPerMinute = 1798;       // a minute with two labels skipped

}  // namespace

int LabelsPerSecond(VideoStandard standard) { return standard == VideoStandard::k625 ? 25 : 30; }

double FramesPerSecond(VideoStandard standard) {
  return standard == VideoStandard::k625 ? 25.0 : 30000.0 / 1001.0;
}

bool Is525(VideoStandard standard) { return standard != VideoStandard::k625; }

std::string StandardName(VideoStandard standard) {
  switch (standard) {
    case VideoStandard::k525NonDrop:
      return "525-ndf";
    case VideoStandard::k525DropFrame:
      return "525-df";
    case VideoStandard::k625:
      return "625";
  }
  return "?";
}

bool IsValidLabel(const take::Timecode& tc, VideoStandard standard) {
  if (tc.hours < 0 || tc.hours > 23 || tc.minutes < 0 || tc.minutes > 59 || tc.seconds < 0 ||
      tc.seconds > 59 || tc.frames < 0 || tc.frames >= LabelsPerSecond(standard)) {
    return false;
  }
  if (standard == VideoStandard::k525DropFrame && tc.seconds == 0 && tc.frames < 2 &&
      tc.minutes % 10 != 0) {
    return false;
  }
  return true;
}

int64_t FrameNumber(const take::Timecode& tc, VideoStandard standard) {
  DOME_CHECK(IsValidLabel(tc, standard), "invalid label " + tc.Text());
  const int64_t fps = LabelsPerSecond(standard);
  const int64_t minutes = tc.hours * 60 + tc.minutes;
  const int64_t labels = (minutes * 60 + tc.seconds) * fps + tc.frames;
  if (standard != VideoStandard::k525DropFrame) return labels;
  return labels - 2 * (minutes - minutes / 10);
}

int64_t FramesPerDay(VideoStandard standard) {
  if (standard == VideoStandard::k525DropFrame) return 144 * kDropFramesPerTenMinutes;
  return int64_t{24} * 3600 * LabelsPerSecond(standard);
}

take::Timecode LabelOf(int64_t n, VideoStandard standard) {
  DOME_CHECK(n >= 0 && n < FramesPerDay(standard), "frame number out of the day");
  int64_t labels = n;
  if (standard == VideoStandard::k525DropFrame) {
    // Put the skipped labels back: 18 per whole ten minutes, 2 per started minute
    // after the first of the ten.
    const int64_t tens = n / kDropFramesPerTenMinutes;
    const int64_t rest = n % kDropFramesPerTenMinutes;
    const int64_t minute_skips = rest < 2 ? 0 : (rest - 2) / kDropFramesPerMinute;
    labels = n + 18 * tens + 2 * minute_skips;
  }
  const int64_t fps = LabelsPerSecond(standard);
  take::Timecode tc;
  tc.frames = static_cast<int>(labels % fps);
  const int64_t s = labels / fps;
  tc.seconds = static_cast<int>(s % 60);
  tc.minutes = static_cast<int>((s / 60) % 60);
  tc.hours = static_cast<int>(s / 3600);
  return tc;
}

std::optional<take::Timecode> ParseTimecode(const std::string& text, VideoStandard standard) {
  if (text.size() != 11) return std::nullopt;
  for (size_t i = 0; i < text.size(); ++i) {
    if (i % 3 == 2) {
      const bool ok = text[i] == ':' || (i == 8 && (text[i] == ';' || text[i] == '.'));
      if (!ok) return std::nullopt;
    } else if (text[i] < '0' || text[i] > '9') {
      return std::nullopt;
    }
  }
  auto two = [&](size_t at) { return (text[at] - '0') * 10 + (text[at + 1] - '0'); };
  const take::Timecode tc{two(0), two(3), two(6), two(9)};
  if (!IsValidLabel(tc, standard)) return std::nullopt;
  return tc;
}

TimecodeRange ParseRange(const std::string& text, VideoStandard standard,
                         const std::string& where) {
  const std::string expected = "a range FIRST-LAST of " + StandardName(standard) +
                               " time codes HH:MM:SS:FF, e.g. 00:00:10:00-00:00:11:20";
  core::Require(text.size() == 23 && text[11] == '-', where,
                "got '" + text + "'; expected " + expected);
  const auto first = ParseTimecode(text.substr(0, 11), standard);
  const auto last = ParseTimecode(text.substr(12), standard);
  core::Require(first && last, where,
                "got '" + text + "': not a valid label on " + StandardName(standard) +
                    "; expected " + expected);
  core::Require(FrameNumber(*first, standard) <= FrameNumber(*last, standard), where,
                "got '" + text + "': the first time code is after the last");
  return {*first, *last};
}

VideoStandard ParseStandard(const std::string& name, const std::string& where) {
  if (name == "525-ndf") return VideoStandard::k525NonDrop;
  if (name == "525-df") return VideoStandard::k525DropFrame;
  if (name == "625") return VideoStandard::k625;
  throw core::InputError(where, "got '" + name + "'; expected 525-ndf, 525-df or 625");
}

}  // namespace dome::capture
