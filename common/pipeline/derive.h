// A session's values derived from its take (rig and images only; never reference or
// truth files), for every field the user left unset. `dome run TAKE` and `dome submit`
// call it before submitting, so the master, the journal's digest and every job see
// plain, explicit values. The rules, each stated where it is applied (derive.cc):
//
//   volume      the scene's box (stereo/scene_extent.h: the region the cameras see in
//               common, narrowed by a coarse stereo pass to where surfaces are), or the
//               box the user gives (dome run --box);
//   voxel       1.5 pixel footprints at the box centre (median over cameras of depth /
//               focal length in pixels), and no finer than the seed's voxel budget
//               (kMaxVoxels: 300^3, the seed's 6 m cube of 20 mm voxels) allows;
//   depths      z_min / z_max: the nearest and farthest box corner over all cameras,
//               +-2 voxels; per camera (camera_depths) the depths of the coarse pass's
//               scene points in its image; the full-range search is also clipped to the
//               part of the box each camera sees, coarse to fine to the box;
//   greys       a dark exposure (99th percentile grey below 128: most of the range
//               unused, shot noise dominant): normalize_contrast and sqrt_greys;
//   large images (>= kLargeImagePx pixels per camera): coarse to fine, window 11,
//               uniqueness 0.02, the two nearest cameras as the cluster, speckle pieces
//               below 1.5 % of the image (step five pixel footprints) dropped, 10
//               Taubin smoothing iterations of mesh.ply;
//   silhouettes each use of the foreground masks (volume, stereo, fusion) on when masks
//               can be made for the take and two cameras find a foreground, else off;
//               with the volume on, the scene's box shrinks to the bounding box of the
//               masks' visual hull (silhouette/hull.h) at 15 of the session's instants
//               at most (evenly spread, as a median background's), grown by the scene
//               extent's margin;
//   fusion      truncation and free-space clamp three voxels (the seed's), one voxel for
//               large images (the budget makes their voxel coarser than their matches'
//               depth error).
// Every value derived is named in Derivation::notes with how it was found; the
// master copies them to OUT/report.json ("derived"), with the volume.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "runtime.pb.h"
#include "take/take.h"

namespace dome::pipeline {

inline constexpr double kMaxVoxels = 300.0 * 300.0 * 300.0;  // the seed's 6 m / 20 mm cube
inline constexpr int kLargeImagePx = 500000;                 // "large images", pixels
// Silhouettes are used when at least two cameras' masks hold this fraction of the
// image as foreground (a person far across a dome covers more than 0.1 %).
inline constexpr double kMinForegroundFraction = 0.001;
inline constexpr int kHullCells = 96;  // the hull's box: cells along the longest side
// The masks' hull is looked for this fraction of the scene's box beyond each of its sides
// (derive.cc HullVolume): where the box came from coarse stereo, only where every camera
// sees it in its foreground; past the view sphere's box (too few coarse points), by the
// hull's own rule.
inline constexpr double kHullBeyondFraction = 0.5;
// A rig is sparse for the silhouettes (derive.cc) when its cameras' median nearest axis
// angle (stereo/cluster.h) exceeds this, degrees: half the widest angle a stereo cluster
// takes (60). The seed's dome pairs cameras about 18 degrees apart (the paper take:
// 17.8), where stereo covers the surface; the small synthetic dome's six cameras (70)
// and Panoptic's five HD ones (47 to 119 degrees apart) leave most of it unmatched.
inline constexpr double kSparseAxisAngleDeg = 30.0;
// Where the hull's surface stands in, the parts under this fraction of the largest
// part's area are specks whatever their size and place (derive.cc says why).
inline constexpr double kSparseSpeckAreaFraction = 0.02;

struct DeriveRequest {
  // The volume to use instead of the scene's box (dome run --box), world mm.
  std::optional<std::pair<Eigen::Vector3d, Eigen::Vector3d>> box;
  int num_threads = 0;  // the coarse pass's threads; 0: all
  // Offer the frames read to this process's workers (frame_handoff.h): true only where
  // in-process workers will run the session (dome run without --master).
  bool offer_frames = false;
};

struct Derivation {
  std::vector<std::string> notes;  // "volume: ... (how)", one per derived value
};

// Fills the unset fields of `session` (its take must be set) from the take. Throws
// core::InputError naming the take or the field when nothing sensible can be derived
// (then the message says which flag to give).
Derivation DeriveSession(const DeriveRequest& request, runtime::Session* session);

}  // namespace dome::pipeline
