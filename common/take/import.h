// Importers: turn calibrated image sets of other tools into takes (take/take.h).
//
// Every importer writes the world in millimetres whatever the source unit, and
// records the source's unit in rig.json (source_unit, source_unit_mm) so outputs can
// be written back in it. Each produces a one-instant take (instant 00-00-00-00 unless
// options say otherwise); images are copied as PNG (re-encoded only when the source
// is another format). Reference geometry shipped with the source (Robovision's
// reference.ply) is copied unchanged, in source units, to TAKE/reference/.
#pragma once

#include <filesystem>
#include <string>

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

// A CMU Panoptic Studio excerpt: DIR/camera_parameters.json ({"cameras": [{"name",
// "type", "resolution": [w, h], "K": 3x3, "distCoef": [k1, k2, p1, p2, k3], "R": 3x3,
// "t": 3x1}]}, world -> camera in centimetres, OpenCV's lens) and the frames
// DIR/hd/<camera>/<camera>_<frame>.jpg. Every camera with a folder under hd/ is
// imported with its exact lens (geometry/tsai_camera.h OpenCvLens); each HD frame
// number becomes an instant, its timecode the frame count at 30 frames a second
// (HD frame 4500 -> 00-02-30-00). Every camera must have the same frames, of its
// calibrated size. Source unit: centimetres.
Take ImportPanoptic(const std::filesystem::path& dir, const std::filesystem::path& out,
                    const ImportOptions& options = {});

}  // namespace dome::take
