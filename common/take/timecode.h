// VITC / SMPTE 12M time codes as dome names instants by them.
//
// Text form HH:MM:SS:FF (HH:MM:SS;FF for drop-frame), folder-name form HH-MM-SS-FF
// (drop-frame is a property of the recording, not of the name). Frames count from 0
// to fps-1 (30 for 525/60, 25 for 625/50).
#pragma once

#include <optional>
#include <string>

namespace dome::take {

struct Timecode {
  int hours = 0;    // 0..23
  int minutes = 0;  // 0..59
  int seconds = 0;  // 0..59
  int frames = 0;   // 0..fps-1

  bool operator==(const Timecode&) const = default;
  auto operator<=>(const Timecode&) const = default;

  // "HH-MM-SS-FF", the folder name of an instant.
  std::string FolderName() const;
  // "HH:MM:SS:FF", or with ';' before the frames for drop-frame.
  std::string Text(bool drop_frame = false) const;
};

// Parses a folder name "HH-MM-SS-FF" (fields in range, frames < 30). nullopt otherwise.
std::optional<Timecode> ParseInstantName(const std::string& name);

}  // namespace dome::take
