// The instants of an output folder as one sequence: what `dome export` delivers.
//
// Input: OUT/<instant>/textured.glb for every instant folder of OUT (HH-MM-SS-FF,
// take/timecode.h), in timecode order, and OUT/report.json's volume.voxel_size_mm when
// the folder was written by `dome run` (absent: 0, unknown). An instant whose textured
// mesh is missing or unreadable stops the load with an error naming the file, or, with
// `skip_missing`, is left out and listed in Sequence::skipped with the reason.
//
// Timeline: instant i plays from (frames of its timecode - frames of the first
// instant's) / fps seconds, until the next instant starts; the last one holds for one
// frame. Geometry stays in dome's world frame, mm, z up.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "mesh/texture.h"
#include "take/timecode.h"

namespace dome::sequence {

struct SequenceInstant {
  std::string name;           // HH-MM-SS-FF
  take::Timecode timecode;
  double start_s = 0;          // on the timeline, seconds from the first instant
  mesh::TexturedMesh textured;  // from OUT/<instant>/textured.glb
};

struct SkippedInstant {
  std::string name;
  std::string reason;  // the error that made it unreadable
};

struct Sequence {
  std::vector<SequenceInstant> instants;
  std::vector<SkippedInstant> skipped;
  double fps = 30;       // timeline frames per second
  double voxel_mm = 0;   // the session's voxel edge; 0 when unknown
  // Seconds from the first instant's start to the end of the last one's frame.
  double duration_s() const;
};

struct LoadOptions {
  // Timeline frames per second: the take's VITC frame rate (30 for 525/60, 25 for 625/50).
  double fps = 30;
  // Leave out instants whose textured mesh is missing or unreadable (listed) instead of
  // stopping.
  bool skip_missing = false;
  // Throws core::InputError naming the option out of range.
  void Check() const;
};

// Reads the sequence of `out`. Throws core::InputError naming the folder when it holds
// no instant, or the file of an unreadable instant (unless skip_missing).
Sequence LoadSequence(const std::filesystem::path& out, const LoadOptions& options);

// Frames from 00:00:00:00 to `timecode` at `fps` frames per second.
double FramesOf(const take::Timecode& timecode, double fps);

}  // namespace dome::sequence
