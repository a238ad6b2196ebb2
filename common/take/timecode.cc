#include "take/timecode.h"

#include <cstdio>

namespace dome::take {

std::string Timecode::FolderName() const {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%02d-%02d-%02d-%02d", hours, minutes, seconds, frames);
  return buf;
}

std::string Timecode::Text(bool drop_frame) const {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%02d:%02d:%02d%c%02d", hours, minutes, seconds,
                drop_frame ? ';' : ':', frames);
  return buf;
}

std::optional<Timecode> ParseInstantName(const std::string& name) {
  if (name.size() != 11) return std::nullopt;
  for (size_t i = 0; i < name.size(); ++i) {
    const bool sep = (i % 3 == 2);
    if (sep ? name[i] != '-' : (name[i] < '0' || name[i] > '9')) return std::nullopt;
  }
  auto two = [&](size_t at) { return (name[at] - '0') * 10 + (name[at + 1] - '0'); };
  Timecode tc{two(0), two(3), two(6), two(9)};
  if (tc.hours > 23 || tc.minutes > 59 || tc.seconds > 59 || tc.frames > 29) return std::nullopt;
  return tc;
}

}  // namespace dome::take
