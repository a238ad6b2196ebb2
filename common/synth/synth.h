// `dome synth`: a synthetic 3D Dome take with ground truth (seed §4.1-4.2).
//
// What it writes (take/take.h gives the take layout):
//   TAKE/rig.json                        the cameras (synth/dome_rig.h), neighbours = clusters
//   TAKE/frames/<instant>/<camera>.png   8-bit grey W x H take images: the first field of the
//                                        NTSC frame, column pairs averaged (synth/render.h)
//   TAKE/tape/<instant>/<camera>.png     8-bit grey 2W x 2H interlaced NTSC frames as taped:
//                                        even rows = first field at t, odd rows = second
//                                        field at t + 1/60 s (for the capture stage)
//   TAKE/tape/<camera>.avi               with write_tape_video: the camera's tape, a lossless
//                                        FFV1 video of its tape frames, one per instant in
//                                        order, with the vertical interval and the instant's
//                                        VITC (capture/tape.h); what `dome-capture --deck
//                                        sim:` plays
//   TAKE/truth/<instant>/mesh.ply        the scene mesh at t (world, mm; binary PLY with
//                                        normals and albedo as grey vertex colours)
//   TAKE/truth/<instant>/depth/<camera>.tiff  z-depth (mm) of the first field, 0 = no surface
//   TAKE/truth/<instant>/mask/<camera>.png     the person's truth mask: 255 where the person
//                                        or the bat is at least half of the take-image
//                                        pixel (synth/render.h RenderedView::person)
//   TAKE/background/<camera>.png         the background plate: the dome without the
//                                        person, as the camera sees it (its own gain,
//                                        offset and noise, a noise stream of its own)
//   TAKE/calib/...                       stage-1 and stage-2 calibration images, targets and
//                                        true image points (proto/calib.proto)
// Instants are named by VITC timecode (take/timecode.h): the first at 00:00:10:00, then
// every 5th frame of 30 -- 6 Hz, as the seed digitized. Instant k is at t = k / 6 s on
// the batter's clock (synth/batter.h).
//
// Reproducibility: the output is a function of the options alone (byte-identical for
// the same options, whatever the thread count); `seed` changes the sensor noise and
// nothing else -- not the scene, the cameras, the truth or the calibration truth.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace dome::synth {

struct SynthPreset {
  std::string name;
  int cameras = 0;
  int instants = 0;
  int width_px = 0;  // take image; the NTSC frame is twice as wide and high
  int height_px = 0;
};

// "paper": the seed's experiment -- 51 cameras, 11 instants, 320 x 245 take images from
// 640 x 490 frames. "small": 6 cameras, 3 instants, 160 x 120 images, for fast tests.
const std::vector<SynthPreset>& SynthPresets();

struct SynthOptions {
  std::string preset = "paper";   // a SynthPresets() name
  uint64_t seed = 1;              // sensor noise only
  std::optional<int> cameras;     // overrides the preset: 1..DomeRigOptions::MaxCameras()
  std::optional<int> instants;    // overrides the preset: 1..kMaxInstants
  std::optional<int> width_px;    // overrides the preset's take image width, pixels
  std::optional<int> height_px;   // overrides the preset's take image height, pixels
  int threads = 0;                // worker threads; 0 = all hardware threads
  bool overwrite = false;         // replace an existing take: when the folder holds a
                                  // rig.json, it and frames/, tape/, truth/, calib/ and
                                  // background/
                                  // are removed first
  bool write_tape = true;         // write tape/
  bool write_tape_video = false;  // also write tape/<camera>.avi (off by default: a video's
                                  // bytes depend on the noise seed, unlike every other
                                  // non-image output; `dome-capture make-tapes` makes them later)
  bool write_calibration = true;  // write calib/
  bool write_background = true;   // write background/ (plates for silhouettes)

  static constexpr int kMaxInstants = 300;

  // The preset with the overrides applied. Throws core::InputError naming the flag
  // (--preset, --cameras, --instants, --width, --height, --threads) at fault.
  SynthPreset Resolve() const;
};

struct SynthSummary {
  SynthPreset scene;  // what was generated
  uint64_t seed = 0;
  std::vector<std::string> instants;  // folder names
  int truth_mesh_vertices = 0;        // of the first instant's mesh
  int truth_mesh_faces = 0;
  // The bat's barrel (70 mm) across, in take-image pixels, over every (camera, instant)
  // where its middle is in view: median, min, max (horizontal pixels).
  double bat_px_median = 0.0, bat_px_min = 0.0, bat_px_max = 0.0;
  // The bat tip's displacement between the two fields of a frame, take-image pixels:
  // the largest over cameras and instants.
  double field_motion_px_max = 0.0;
  // Calibration points with truth, fewest per camera: stage 1 (of 147), stage 2 (of
  // AllFloorMarkPoints(): the 25 of the grid and the plain marks a camera sees).
  int stage1_points_min = 0;
  int stage2_points_min = 0;
  int files_written = 0;
  double seconds = 0.0;  // wall time

  std::string BriefReport() const;
};

// Generates the take into `out_dir`. Throws core::InputError naming the option or the
// folder at fault (existing take without overwrite, folder not creatable or writable).
SynthSummary GenerateTake(const SynthOptions& options, const std::filesystem::path& out_dir);

// Instant folder name of instant k (00-00-10-00, 00-00-10-05, ...) and its time, s.
std::string InstantName(int k);
double InstantTimeS(int k);
// Exposure delay of the second field after the first, in seconds (NTSC: 1/60 s).
inline constexpr double kFieldDelayS = 1.0 / 60.0;

}  // namespace dome::synth
