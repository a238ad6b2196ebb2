// Importers: turn calibrated image sets of other tools into takes (take/take.h).
//
// Every importer writes the world in millimetres whatever the source unit, and
// records the source's unit in rig.json (source_unit, source_unit_mm) so outputs can
// be written back in it. A source with one set of images gives a one-instant take
// (instant 00-00-00-00 unless options say otherwise), one with several instants a
// multi-instant take; images are copied as PNG (re-encoded only when the source is
// another format) and must be of the calibrated size. Importers write through
// TakeWriter (take/take.h): on any error nothing is left half written. Reference geometry shipped
// with the source (Robovision's reference.ply) is copied unchanged, in source units, to
// TAKE/reference/.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "take/take.h"

namespace dome::take {

struct ImportOptions {
  std::string instant = "00-00-00-00";  // instant folder name (timecode HH-MM-SS-FF)
  bool overwrite = false;               // replace an existing take at the output folder

  // Throws core::InputError naming the option when out of range.
  void Check() const;
};

// A Robovision scene folder (HALCON 12 files, see geometry/halcon.h):
// intrinsics_cameraNN.txt, extrinsics_cameraNN.txt, image_cameraNN.png and
// optionally reference.ply. Camera ids are "cameraNN". Source unit: metres.
Take ImportHalconScene(const std::filesystem::path& scene_dir, const std::filesystem::path& out,
                       const ImportOptions& options = {});

// A Middlebury multi-view set: the *_par.txt file (geometry/middlebury.h) and the
// images it names, in the same folder. Camera ids are the image names without
// extension. Source unit: metres. Image sizes are read from the images.
Take ImportMiddlebury(const std::filesystem::path& par_file, const std::filesystem::path& out,
                      const ImportOptions& options = {});

// A COLMAP text model (cameras.txt, images.txt; geometry/colmap.h) and the folder of
// its images. COLMAP models have no absolute scale: `mm_per_unit` says how many
// millimetres one model unit is. Camera ids are the image names without extension.
Take ImportColmap(const std::filesystem::path& sparse_dir, const std::filesystem::path& images_dir,
                  const std::filesystem::path& out, double mm_per_unit,
                  const ImportOptions& options = {});

// CMU Panoptic Studio: a calibration JSON ({"cameras": [{"name", "type",
// "resolution": [w, h], "K": 3x3, "distCoef": [k1, k2, p1, p2, k3], "R": 3x3, "t": 3x1}]},
// world -> camera in centimetres, OpenCV's lens) and a folder of frames
// <images_dir>/<camera>/<camera>_<frame>.jpg|png (Panoptic's hd/ or vga/). Each camera
// keeps its exact lens (geometry/tsai_camera.h OpenCvLens). Each frame number becomes
// an instant, its timecode the frame count at 30 frames a second (HD frame 4500 ->
// 00-02-30-00); every imported camera must have the same frames, of its calibrated
// size. Source unit: centimetres.
struct PanopticOptions {
  // Cameras to import, by name. Empty: every calibrated camera that has a frame
  // folder, or every calibrated camera when there are no images (a rig-only take).
  // A named camera must be calibrated, and must have frames when there are images.
  std::vector<std::string> cameras;
};
// `images_dir` empty: a rig-only take (rig.json, no instants), e.g. the whole
// 520-camera dome of a calibration session.
Take ImportPanoptic(const std::filesystem::path& calibration,
                    const std::filesystem::path& images_dir, const std::filesystem::path& out,
                    const PanopticOptions& panoptic = {}, const ImportOptions& options = {});

// Per-camera OpenCV FileStorage files (YAML, XML or JSON: what cv::FileStorage and
// OpenCV's calibration tools write), <calib_dir>/<camera>.yml|yaml|xml|json, the
// camera id being the file name's stem. Each holds
//   the image size: image_width and image_height, or image_size / imageSize [w, h];
//   K: camera_matrix, cameraMatrix or K (3x3);
//   D: distortion_coefficients, distCoeffs, dist_coeffs or D (4, 5, 8, 12 or 14;
//      see geometry/opencv_camera.h for what dome can hold);
//   the pose, world -> camera: R (3x3) or rvec (Rodrigues, 3), and T, t or tvec (3),
//      in a unit of which `mm_per_unit` millimetres make one.
// Images: <images_dir>/<camera>.<png|jpg|...> (one instant, options.instant) or
// <images_dir>/<camera>/ holding numbered frames (take/import_frames.h: the frame
// number at 30 frames a second names the instant), the same numbers for every
// camera. `images_dir` empty: a rig-only take.
Take ImportOpenCv(const std::filesystem::path& calib_dir, const std::filesystem::path& images_dir,
                  const std::filesystem::path& out, double mm_per_unit,
                  const ImportOptions& options = {});

// Video: one file per camera, <video_dir>/<camera>.<any extension>, in any container
// and codec OpenCV's video reader (FFmpeg) decodes, each frame the camera's image at
// one instant. The take's timeline counts frames at `fps` from 00:00:00:00; a
// camera's video frame i is timeline frame i + its offset. Each frame is decoded
// once, in order, and written before the next is read: memory holds one frame.
struct VideoImportOptions {
  // The timeline frame of a camera's first video frame, by camera id (default 0).
  std::map<std::string, long> offset_frames;
  // Or the timecode of a camera's first frame ("HH:MM:SS:FF" or "HH-MM-SS-FF").
  std::map<std::string, std::string> start_timecodes;
  // Frames to import, as timeline frame numbers or timecodes. `range`: {first, last}
  // inclusive, default the span every camera covers; `every`: every Nth frame of it;
  // `instants`: exactly these frames instead of range and every.
  std::vector<std::string> range;
  int every = 1;
  std::vector<std::string> instants;
  // Timeline rate, frames a second (1..30, timecodes count frames below 30); 0: the
  // videos' own rate, rounded, which must agree between cameras.
  int fps = 0;

  // Throws core::InputError naming the option when out of range.
  void Check() const;
};
Take ImportVideo(const geometry::Rig& rig, const std::filesystem::path& video_dir,
                 const std::filesystem::path& out, const VideoImportOptions& video,
                 const ImportOptions& options = {});

}  // namespace dome::take
