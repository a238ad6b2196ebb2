// Full validation of a take folder (take/take.h), as `dome info` runs it.
//
// Unlike OpenTake, which stops at the first error, ValidateTake reports every
// problem it finds, each naming the file (and field) and what was expected.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "take/take.h"

namespace dome::take {

struct TakeProblem {
  std::string where;  // file, or "file: field"
  std::string what;   // what is wrong and what was expected
  std::string Text() const { return where + ": " + what; }
};

struct TakeReport {
  std::filesystem::path dir;
  bool rig_ok = false;
  geometry::Rig rig;                  // valid when rig_ok
  std::vector<std::string> instants;  // sorted instant folder names found
  int images_checked = 0;
  bool has_calib = false;
  int calib_files = 0;
  bool has_truth = false;
  int truth_instants = 0;
  int mask_instants = 0;      // instant folders under masks/ (given masks)
  int background_plates = 0;  // background/<camera>.png of rig cameras
  std::vector<TakeProblem> problems;

  bool ok() const { return problems.empty(); }
  // Human-readable summary: cameras (id, size, focal length in pixels, centre
  // position), instants (timecodes), calibration and truth, then the problems.
  std::string Summary() const;
};

struct ValidateOptions {
  // Decode every image (catches corrupt files); false only checks presence.
  bool decode_images = true;
};

TakeReport ValidateTake(const std::filesystem::path& dir, const ValidateOptions& options = {});

}  // namespace dome::take
