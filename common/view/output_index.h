// What the viewer shows: the instants of an output folder, the files each one has,
// the rig's cameras as frusta, and where each camera's image, depth map and foreground
// mask are.
//
// Output folder (what `dome fuse`, `dome mesh`, `dome stereo` and `dome run` write):
//   OUT/<instant>/mesh.ply              fused mesh, binary PLY, world mm
//   OUT/<instant>/mesh_decimated.ply    decimated mesh with per-vertex colour
//   OUT/<instant>/textured.glb          textured mesh (glTF binary), when written
//   OUT/<instant>/textured.obj/.mtl/.png  textured mesh, OBJ + atlas
//   OUT/<instant>/depth/<camera>.tiff   stereo depth, 32-bit float, mm
//   OUT/<instant>/preview/<camera>.png  colour-mapped stereo depth (dome stereo)
//   OUT/*.dome4d                        4D files (dome export), played as a source
// Take (optional, --take): TAKE/rig.json, TAKE/frames/<instant>/<camera>.png,
// TAKE/truth/<instant>/mesh.ply and TAKE/truth/<instant>/depth/<camera>.tiff; a camera's
// masks are those of silhouette/take_masks.h (given, from a background plate, or from
// the median over the take's instants).
//
// <instant> is HH-MM-SS-FF (take/timecode.h); an instant is listed when OUT or the
// take's frames have a folder for it, so an instant whose meshes were never written
// still appears (and the page shows it as missing).
//
// URLs in the index are relative to the page: "out/<path in OUT>", "take/<path in
// TAKE>", "derived/depth/<instant>/<camera>.png" (a depth TIFF colour-mapped by the
// server or at export) and "derived/error/<instant>/<variant>.f32" (per-vertex
// distance to the truth mesh, little-endian float32, mm, in the PLY's vertex order) and
// "derived/mask/<instant>/<camera>.png" (the image darkened outside the camera's mask,
// with its outline: silhouette::MaskPreview).
#pragma once

#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "geometry/rig.h"
#include "geometry/tsai_camera.h"

namespace dome::view {

// A camera drawn as a pyramid: its centre and the world points seen at the four
// image corners at `depth_mm` along its optical axis (world frame, mm). Corners are
// in image order: top-left, top-right, bottom-right, bottom-left.
struct CameraFrustum {
  std::string id;
  int width_px = 0;
  int height_px = 0;
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();
  std::array<Eigen::Vector3d, 4> corners_mm;
};

// The frustum of `camera` cut at camera depth `depth_mm` (> 0). Corners are the outer
// edges of the corner pixels, back-projected through the camera's distortion.
CameraFrustum FrustumOf(const geometry::TsaiCamera& camera, double depth_mm);

// A frustum depth that reads well for the whole rig: 8% of the largest distance
// between two camera centres (400 mm for the 5 m dome), 300 mm for a single camera.
double DefaultFrustumDepthMm(const geometry::Rig& rig);

// Which mesh of an instant a per-vertex error refers to.
enum class MeshVariant { kFused, kDecimated };
const char* VariantName(MeshVariant variant);  // "fused", "decimated"

struct CameraFiles {
  std::string image;                // path in TAKE of the instant's image; "" when absent
  std::string depth_preview;        // path in OUT of a preview PNG written by dome stereo; ""
  std::filesystem::path depth_map;  // depth TIFF to colour-map (OUT, else truth); ""
  std::string depth_source;         // "stereo" or "truth"; "" when no depth
  bool mask = false;                // the image exists and its camera has masks
};

struct InstantEntry {
  std::string name;   // HH-MM-SS-FF
  std::string label;  // HH:MM:SS:FF, the VITC text
  // Paths in OUT, "" when the file is absent.
  std::string fused, decimated, textured_glb, textured_obj, textured_png;
  std::filesystem::path truth_mesh;  // TAKE/truth/<instant>/mesh.ply, "" when absent
  std::vector<CameraFiles> cameras;  // one per ViewerIndex::cameras entry
};

struct IndexOptions {
  // Frustum depth, in mm; <= 0 picks DefaultFrustumDepthMm.
  double frustum_depth_mm = 0.0;
  // Error (distance to truth) at the top of the colour scale, in mm.
  double error_range_mm = 40.0;
  // Playback rate the page starts with, in instants per second (the seed's 6 Hz).
  double play_rate_hz = 6.0;
};

struct ViewerIndex {
  std::filesystem::path out_dir;
  std::optional<std::filesystem::path> take_dir;
  IndexOptions options;
  std::vector<CameraFrustum> cameras;
  std::vector<InstantEntry> instants;  // in time order
  // 4D files of `dome export` at OUT's top level (OUT/*.dome4d), paths in OUT, sorted.
  std::vector<std::string> sequences;
  // Per camera (as `cameras`), where its masks come from: "given", "plate" or "median"
  // (silhouette::MaskSourceName); all "" when the take offers none, and then
  // `masks_unavailable` says why (the take's error, e.g. too few instants for a median).
  std::vector<std::string> mask_sources;
  std::string masks_unavailable;

  // Index of the instant with this folder name, or -1.
  int FindInstant(const std::string& name) const;
  // Index of the camera with this id, or -1.
  int FindCamera(const std::string& id) const;
};

// Scans OUT (and TAKE when given). Throws core::InputError naming the folder when
// OUT is not a folder, or naming the file and field when the take is malformed.
ViewerIndex BuildIndex(const std::filesystem::path& out_dir,
                       const std::optional<std::filesystem::path>& take_dir,
                       const IndexOptions& options = {});

// The index as the page reads it: a JSON object (see the header comment for URLs).
// `packed` marks an export whose binary files are wrapped in scripts (export.h); it
// lists no 4D file (those play only over HTTP).
std::string IndexJson(const ViewerIndex& index, bool packed);

}  // namespace dome::view
