// A session (proto/runtime.proto Session): a take, an output folder and the options
// of every stage, resolved against the libraries' defaults.
//
// File: SESSION.json, the protobuf JSON of dome.runtime.Session, e.g.
//   {"take": "/data/take1", "out": "/data/out1", "instants": ["00-00-00-00"],
//    "stereo": {"window_sizes_px": [7]}, "volume": {"voxel_size_mm": 40},
//    "slab_planes": 16, "decimate_ratio": 0.1, "texture": true}
// Unknown fields are rejected naming the field; unset fields take the defaults below.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "fusion/integrate.h"
#include "fusion/volume.h"
#include "mesh/decimate.h"
#include "mesh/smooth.h"
#include "pipeline/settings.h"
#include "runtime.pb.h"
#include "stereo/take_stereo.h"
#include "take/take.h"

namespace dome::pipeline {

struct SessionOptions {
  stereo::TakeStereoOptions stereo;  // write_previews: preview PNGs beside the depth maps
  fusion::VolumeGrid grid;           // default: the seed's 6 m cube (pipeline/defaults.h)
  fusion::FusionOptions fusion;      // truncation and clamp default to 3 voxels, mm
  int slab_planes = 16;              // voxel planes per fusion job (count)
  double decimate_ratio = 0.1;       // fraction of triangles kept, (0, 1]; 1: not decimated
  bool texture = true;               // also write textured.obj/.mtl/.png
  mesh::SmoothOptions smooth;        // of the marching-cubes surface (mesh.ply); off
  // Clean output (runtime.proto Session): specks are the parts of the surface with less
  // than speck_area_fraction of the largest part's area, a bounding-box diagonal under
  // speck_diagonal_voxels voxels and no vertex within speck_gap_voxels voxels of a part
  // that is not small. A dome instant's surface is one large part (floor, people, what
  // stands on the floor) and thousands of specks that stereo's wrong matches leave in
  // the air: on the paper take's instants about 7,000 parts holding 24-28 % of the
  // triangles, all under 0.3 % of the largest part's area and under 20 voxels across
  // (the smallest real part a dome holds, a bat, is over 40), most of them 40-90 voxels
  // from the surface. The few within 2 voxels of it lie in its truncation band: they are
  // the surface's own noise, and dropping them cost completeness at 20 mm (0.0035 on the
  // paper take; 0.002 with the gap). Dimensionless [0, 1), voxels >= 0; 0 area or
  // diagonal: none.
  double speck_area_fraction = 0.01;
  double speck_diagonal_voxels = 20.0;
  double speck_gap_voxels = 2.0;
  SilhouetteUse silhouettes;  // the masks' uses; off unless the session says (derive.h)
  // Time-aware stereo; off unless the session says, and off for one instant
  // (PlanSession). Off by default: on the paper take it searched 2.8x longer without
  // masks (the tiled bounded search's cost over the whole image) and the same with
  // them (the hull already limits the search to the moving foreground), with no less
  // flicker (README "Time-aware stereo").
  TemporalUse temporal;

  // Throws core::InputError naming the first bad option ("slab_planes").
  void Check() const;
};

// The decimation stage's options from the session's: the ratio, and the speck rule in
// mm (its voxel counts times the voxel). Every command and the decimate job use it.
mesh::DecimationOptions DecimationFor(const SessionOptions& options);

// Reads SESSION.json; errors name the file and the field.
runtime::Session ReadSessionJson(const std::filesystem::path& path);

// The session's options with defaults filled in and checked. `where` names the source
// in errors ("session", a file). Does not open the take.
SessionOptions ResolveSessionOptions(const runtime::Session& session, const std::string& where);

// The instants to reconstruct: the session's list (each checked against the take) or
// every instant of the take, in time order.
std::vector<std::string> SessionInstants(const runtime::Session& session, const take::Take& take);

// A session as the master runs it, fixed at submit (pipeline/stage.h: what the stages
// make their jobs from).
struct SessionPlan {
  runtime::Session spec;
  SessionOptions options;
  take::Take take;                                    // empty for no-op sessions
  std::vector<std::string> instants;                  // in time order ("noop" for a no-op session)
  std::vector<std::string> cameras;                   // rig order
  int num_slabs = 0;                                  // fusion jobs per instant
  runtime::BlobRef rig;                               // TAKE/rig.json
  std::vector<std::vector<runtime::BlobRef>> frames;  // [instant][camera], rig order
  // With silhouettes in stereo or fusion: what each camera's foreground mask is made
  // from by the masks stage's job (jobs.h; proto/runtime.proto MaskJob), [instant]
  // [camera], rig order: given, the mask file; plate, the frame and the plate; median,
  // the frame and the camera's frames at the median's instants. Its source per camera
  // in mask_sources (silhouette::MaskSourceName). Empty otherwise.
  std::vector<std::vector<std::vector<runtime::BlobRef>>> mask_inputs;
  std::vector<std::string> mask_sources;
};

// Resolves and checks the session, opens its take and checks every camera's stereo
// cluster (a bad rig fails the submit, not a worker); the take's rig and frames become
// blobs through `add_file(path, name)`. Throws core::InputError naming the session
// field or the take's file.
SessionPlan PlanSession(const runtime::Session& spec,
                        const std::function<runtime::BlobRef(const std::filesystem::path&,
                                                             const std::string&)>& add_file);

// What a session's journal is keyed on (master/journal.h): the SHA-256 of its take
// folder, instants and every resolved option (not its id, not its output folder).
std::string SessionDigest(const SessionPlan& plan);

// The SHA-256 of a session as given, before DeriveSession (pipeline/derive.h) fills in
// what it left unset, with `extra` (what else steers the derivation: `dome run --box`)
// appended; its given_sha256 and derived notes are left out. Deterministic protobuf
// bytes, so equal sessions give equal digests.
std::string GivenSessionDigest(const runtime::Session& given, const std::string& extra);

// What the jobs of each instant (plan.instants' order) are made from, beyond the
// options: the SHA-256 of the rig's and that instant's frames' content addresses (with
// temporal stereo or fusion, the previous instant's digest too: its depths bound this
// one's search, its fused evidence is in this one's slabs). The
// journal keeps it with each record, so that a take whose files changed under the
// same path redoes exactly the instants whose inputs changed.
std::vector<std::string> InstantInputsDigests(const SessionPlan& plan);

}  // namespace dome::pipeline
