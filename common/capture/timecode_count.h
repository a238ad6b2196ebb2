// Counting frames by SMPTE 12M time-code labels.
//
// A time code labels a frame HH:MM:SS:FF (take/timecode.h). The video standard fixes
// how labels follow one another:
//   k525NonDrop   525/60 (29.97 frames/s), 30 labels a second, every label used;
//   k525DropFrame 525/60 drop-frame: labels FF = 00 and 01 are skipped at the start of
//                 every minute except minutes 00, 10, 20, 30, 40, 50, so the labels
//                 keep pace with the 29.97 Hz clock (17982 frames every ten minutes);
//   k625          625/50 (25 frames/s), 25 labels a second.
// A frame number is the count of frames since 00:00:00:00 on that standard's tape.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "take/timecode.h"

namespace dome::capture {

enum class VideoStandard { k525NonDrop, k525DropFrame, k625 };

// Labels per second (30 or 25), and frames per second of the video (29.97 or 25).
int LabelsPerSecond(VideoStandard standard);
double FramesPerSecond(VideoStandard standard);
bool Is525(VideoStandard standard);
// "525-ndf", "525-df", "625".
std::string StandardName(VideoStandard standard);

// Whether `tc` names a frame on this standard (fields in range; not a skipped
// drop-frame label).
bool IsValidLabel(const take::Timecode& tc, VideoStandard standard);

// Frame number of a valid label; DOME_CHECKs validity (callers validate input first).
int64_t FrameNumber(const take::Timecode& tc, VideoStandard standard);
// The label of frame number `n` (0 <= n < one day of frames).
take::Timecode LabelOf(int64_t n, VideoStandard standard);
// Frames in one day (the labels wrap at 24 h).
int64_t FramesPerDay(VideoStandard standard);

// Parses "HH:MM:SS:FF" or "HH:MM:SS;FF" (';' or '.' before the frames is accepted as
// the drop-frame spelling). nullopt unless the text has that shape and is a valid
// label on `standard`.
std::optional<take::Timecode> ParseTimecode(const std::string& text, VideoStandard standard);

// An inclusive range of frames [first, last] by label.
struct TimecodeRange {
  take::Timecode first;
  take::Timecode last;
};
// Parses "TC-TC" (each as ParseTimecode). Throws core::InputError naming `where`
// when malformed, invalid on `standard` or reversed.
TimecodeRange ParseRange(const std::string& text, VideoStandard standard, const std::string& where);

// "525-ndf", "525-df" or "625". Throws core::InputError naming `where` otherwise.
VideoStandard ParseStandard(const std::string& name, const std::string& where);

}  // namespace dome::capture
