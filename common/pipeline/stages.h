// The pipeline's stages as plain functions (SPEC.md "Pipeline"): one function per
// stage, called by the runtime's jobs (pipeline/jobs.cc), by `dome stereo`, `dome fuse`
// and `dome mesh`, and by the benchmarks, so that every path computes the same bytes.
// No sockets, no wire types: images, range images, slabs and meshes in and out.
//
//   stereo    Stereo: one reference view and its cluster -> range images (depth mm)
//   fusion    PrepareFusion once per instant, then FuseSlab per slab of planes
//   surface   Surface: the slabs in plane order -> the marching-cubes mesh, smoothed
//   decimate  Decimate: the surface -> the decimated mesh (ratio 1: unchanged)
//   texture   Texture: per-vertex colours and, optionally, the texture atlas
//
// Meshes are in world mm (take/take.h); the files a stage writes are listed where it
// writes them (stereo/take_stereo.h for range images, TexturedFiles below).
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fusion/hull_fusion.h"
#include "fusion/integrate.h"
#include "fusion/temporal_carry.h"
#include "fusion/volume.h"
#include "io/mesh.h"
#include "mesh/decimate.h"
#include "mesh/smooth.h"
#include "mesh/texture.h"
#include "silhouette/hull.h"
#include "stereo/multi_baseline.h"
#include "stereo/search_bounds.h"
#include "stereo/take_stereo.h"
#include "take/take.h"

namespace dome::pipeline {

// ---- stereo ---------------------------------------------------------------------------

// The range images of `input`'s reference view: the full-range search, or, with
// options.coarse_to_fine, coarse to fine with the reference camera's depth range
// clipped to its box. result.camera is the reference camera's id. Errors name `where`.
// With `bounds`: it is called with the reference camera's final depth range (z_min,
// z_max mm, after the camera's own range and the clip box) and its search bounds limit
// the search (stereo/search_bounds.h; ComputeDepthBounded, or the coarse-to-fine
// search's tiles).
// With `grey_keys` (one per view, the reference first: pipeline/ideal_greys.h
// IdealGreyKey of its whole frame), the views coarse to fine cuts to its clip box take
// their ideal greys from the process's store (each frame is cut the same way in every
// job of the session, and is a view of about three jobs) instead of making them again;
// empty: each job makes its own. The same bits either way.
using MakeSearchBounds = std::function<stereo::SearchBounds(double z_min_mm, double z_max_mm)>;
stereo::StereoResult Stereo(const stereo::StereoInput& input,
                            const stereo::TakeStereoOptions& options, const std::string& where,
                            const MakeSearchBounds& bounds = nullptr,
                            const std::vector<std::string>& grey_keys = {});

// `dome stereo`: Stereo for every (instant, camera) asked for (empty = all) of the take
// at `take_dir`, written under `out_dir` (stereo/take_stereo.h layout). Errors name the
// camera, instant or file at fault.
std::vector<stereo::StereoResult> RunTakeStereo(const std::filesystem::path& take_dir,
                                                const std::string& camera_id,
                                                const std::string& instant,
                                                const std::filesystem::path& out_dir,
                                                const stereo::TakeStereoOptions& options);

// ---- fusion ---------------------------------------------------------------------------

// The inputs of one instant's fusion, tabulated: what every slab of the instant shares
// (building it costs about as much as fusing a slab). Not changed by FuseSlab: one may
// serve several threads' slabs at once (`dome run`'s workers share it, jobs.cc).
struct PreparedFusion {
  std::vector<fusion::RangeImage> images;  // referenced by `integrator`
  std::unique_ptr<fusion::Integrator> integrator;
  // The visual hull that corrects every slab (fusion/hull_fusion.h); null: none.
  std::shared_ptr<const silhouette::VisualHull> hull;
  // The hull carved by photo-consistency (silhouette/photo_hull.h); null: not carved.
  std::shared_ptr<const silhouette::PhotoHull> photo_hull;
  fusion::HullFusionOptions hull_options;  // how (its num_threads: options')
  fusion::FusionOptions options;
  // Time-aware fusion (fusion/temporal_carry.h): each camera's changed tiles since the
  // previous instant; empty: off.
  std::vector<fusion::ChangeView> change_views;
  fusion::TemporalCarryOptions carry;
};

// Range images in the order given: the accumulation order is fixed by it, so every run
// gives the same bits. Each image is kept as the rectangle of its depths (its camera
// cut to match, take/crop.h); images without a depth are left out.
std::unique_ptr<PreparedFusion> PrepareFusion(
    const fusion::VolumeGrid& grid, std::vector<fusion::RangeImage> images,
    const fusion::FusionOptions& options,
    std::shared_ptr<const silhouette::VisualHull> hull = nullptr,
    const fusion::HullFusionOptions& hull_options = {});
// A camera's depth map given as a rectangle of its full map (a stereo result as it
// travels, pipeline/jobs.h DecodeStereoRects) made the range image PrepareFusion keeps of
// the full map, without making the full map: the rectangle of its depths grown by a
// pixel and clipped to the image, the camera cut to match; nullopt when it holds no
// depth. Throws core::InputError naming `where` when the full map is not the camera's
// size or a value is not a depth (the pixel given in the full map), as PrepareFusion
// would.
std::optional<fusion::RangeImage> CutRangeImage(const geometry::TsaiCamera& camera,
                                                const cv::Mat& depth_rect,
                                                const stereo::MapCut& cut,
                                                const std::string& where);
// Fuses planes [k0, k1) into `slab` (its buffers reused when the size repeats),
// corrected by the hull when there is one, then, with `previous` (the same planes at the
// previous instant, as this function returned them then) and change views, steadied by
// its evidence where nothing changed (fusion/temporal_carry.h); returns *slab. Runs on
// `num_threads` threads (<= 0: prepared.options'), with the same result on any number.
// Errors name `where`.
const fusion::Slab& FuseSlab(const PreparedFusion& prepared, fusion::Slab* slab, int k0, int k1,
                             const fusion::Slab* previous = nullptr,
                             const std::string& where = "fusion",
                             fusion::TemporalCarryStats* carried = nullptr, int num_threads = 0);

// The slabs of a volume of `slab_planes` planes each: how many, and slab s's planes.
int SlabCount(const fusion::VolumeGrid& grid, int slab_planes);
std::pair<int, int> SlabPlanes(const fusion::VolumeGrid& grid, int slab_planes, int s);

// ---- surface --------------------------------------------------------------------------

// The marching-cubes surface of the slabs, fetched one at a time in plane order by
// `slab(index)` (index 0 = planes from 0) and stitched as they come (memory: one slab),
// then Taubin-smoothed (mesh/smooth.h; off by default). Throws core::InputError when
// the slabs do not cover the volume's planes.
io::Mesh Surface(const fusion::VolumeGrid& grid, int num_slabs,
                 const std::function<std::shared_ptr<const fusion::Slab>(int index)>& slab,
                 const mesh::SmoothOptions& smooth);

// ---- decimate -------------------------------------------------------------------------

// `surface` decimated (mesh/decimate.h); a target ratio of 1 keeps it as it is.
io::Mesh Decimate(const io::Mesh& surface, const mesh::DecimationOptions& options,
                  mesh::DecimationSummary* summary = nullptr);

// ---- texture --------------------------------------------------------------------------

struct TextureResult {
  io::Mesh coloured;                        // the mesh with per-vertex colours (mesh_decimated.ply)
  std::optional<mesh::TexturedMesh> atlas;  // with `atlas`: the texture atlas
};

// Colours `decimated` from the views (mesh/texture.h) and, with `atlas`, builds its
// texture atlas.
TextureResult Texture(io::Mesh decimated, const std::vector<mesh::TextureView>& views,
                      const mesh::TextureOptions& options, bool atlas);

// A file a stage writes under OUT/<instant>/: its name and its bytes.
struct NamedFile {
  std::string name;
  std::string bytes;
};

// The textured mesh's files: textured.obj, textured.mtl, textured.png (OBJ + MTL + PNG
// atlas, naming each other) and textured.glb (the same mesh, one binary glTF, holding
// the same PNG), made on `num_threads` threads (<= 0: the hardware's; the same bytes on
// any number).
std::vector<NamedFile> TexturedFiles(const mesh::TexturedMesh& textured, int num_threads = 1);
inline constexpr const char* kMeshPly = "mesh.ply";
inline constexpr const char* kDecimatedPly = "mesh_decimated.ply";
inline constexpr const char* kTexturedObj = "textured.obj";
inline constexpr const char* kTexturedMtl = "textured.mtl";
inline constexpr const char* kTexturedPng = "textured.png";
inline constexpr const char* kTexturedGlb = "textured.glb";
// What decimation did to an instant's surface: DecimationSummaryJson, one object.
inline constexpr const char* kDecimationJson = "decimation.json";

// A decimation's summary as JSON (triangles in and out; the small parts and specks
// dropped first and the parts deleted whole, each with their triangles; the largest
// error estimate, mm; seconds), as `dome mesh decimate` prints it and decimation.json
// holds it.
std::string DecimationSummaryJson(const mesh::DecimationSummary& summary);

// The PLY bytes dome writes for meshes (binary little-endian, "units mm").
std::string EncodeMeshPly(const io::Mesh& mesh);

}  // namespace dome::pipeline
