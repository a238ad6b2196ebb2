#include "pipeline/settings.h"

#include <cmath>

#include "core/error.h"
#include "io/file_util.h"
#include "pipeline/defaults.h"
#include "schema/json.h"

namespace dome::pipeline {

using stereo::CoarseToFineOptions;
using stereo::TakeStereoOptions;

const std::vector<SettingField<TakeStereoOptions>>& StereoSettingFields() {
  using O = TakeStereoOptions;
  static const std::vector<SettingField<O>> fields = {
      {"z_min_mm", "--z-min", "nearest depth, mm",
       +[](O& o) -> double& { return o.stereo.z_min_mm; }},
      {"z_max_mm", "--z-max", "farthest depth, mm",
       +[](O& o) -> double& { return o.stereo.z_max_mm; }},
      {"num_levels", "--levels", "depth levels (0 = from the geometry)",
       +[](O& o) -> int& { return o.stereo.num_levels; }},
      {"level_step_px", "--level-step", "parallax per level in the widest-baseline neighbour, px",
       +[](O& o) -> double& { return o.stereo.level_step_px; }},
      {"window_sizes_px", "--windows", "SSD window sides, px (odd; one range image each)",
       +[](O& o) -> std::vector<int>& { return o.stereo.window_sizes_px; }},
      {"normalize_contrast", "--normalize-contrast",
       "stretch each image's 1st..99th grey percentile to 0..255 (dark images)",
       +[](O& o) -> bool& { return o.stereo.normalize_contrast; }},
      {"sqrt_greys", "--sqrt-greys",
       "match the square roots of the greys (shot noise levelled; dim images)",
       +[](O& o) -> bool& { return o.stereo.sqrt_greys; }},
      {"clip_pad_mm", "", "added to each end of a clipped depth range, mm",
       +[](O& o) -> double& { return o.clip_pad_mm; }},
      {"outside_difference_grey", "--outside-difference",
       "cost of a sample outside a neighbour's image, as a grey difference",
       +[](O& o) -> double& { return o.stereo.outside_difference_grey; }},
      {"min_curvature", "--min-curvature", "least cost curvature, grey^2 per level^2 per sample",
       +[](O& o) -> double& { return o.stereo.min_curvature; }},
      {"min_uniqueness", "--min-uniqueness", "least margin of the second-best cost over the best",
       +[](O& o) -> double& { return o.stereo.min_uniqueness; }},
      {"min_texture_grey", "--min-texture", "least grey standard deviation in the window",
       +[](O& o) -> double& { return o.stereo.min_texture_grey; }},
      {"max_neighbours", "--max-neighbours",
       "cluster size without the reference, when rig.json names none",
       +[](O& o) -> int& { return o.cluster.max_neighbours; }},
      {"max_axis_angle_deg", "--max-axis-angle",
       "largest angle between the optical axes of a cluster, degrees",
       +[](O& o) -> double& { return o.cluster.max_axis_angle_deg; }},
      {"prewarp_neighbours", "!--exact-warp",
       "warp the neighbours per pixel and level instead of pre-warping them once (slower)",
       +[](O& o) -> bool& { return o.stereo.prewarp_neighbours; }},
      {"speckle_area_px", "--speckle-area",
       "drop depth pieces of fewer pixels (0 = keep all; stereo/speckle.h)",
       +[](O& o) -> int& { return o.stereo.speckle.min_area_px; }},
      {"speckle_step_mm", "--speckle-step", "largest depth step within one piece, mm",
       +[](O& o) -> double& { return o.stereo.speckle.max_step_mm; }},
  };
  return fields;
}

const std::vector<SettingField<TemporalUse>>& TemporalSettingFields() {
  using O = TemporalUse;
  static const std::vector<SettingField<O>> fields = {
      {"stereo", "--temporal",
       "search each instant after the first around the previous instant's depths where its "
       "images are still (default: off; each instant over its whole range)",
       +[](O& o) -> bool& { return o.stereo; }},
      {"tile_px", "--temporal-tile-px",
       "tiles judged still or changed as a whole, px (default 32: the bounded search's)",
       +[](O& o) -> int& { return o.bounds.tile_px; }},
      {"margin_levels", "--temporal-margin-levels",
       "search levels either side of the previous instant's depths (default 8)",
       +[](O& o) -> double& { return o.bounds.margin_levels; }},
      {"change_factor", "--temporal-change-factor",
       "a tile changed above this many times the image's median grey difference (default 3)",
       +[](O& o) -> double& { return o.bounds.change_factor; }},
      {"change_floor_grey", "--temporal-change-floor",
       "... plus this many greys, 0..255 (default 2)",
       +[](O& o) -> double& { return o.bounds.change_floor_grey; }},
      {"outlier_fraction", "--temporal-outlier-fraction",
       "fraction of a tile's previous depths left out at either end of its range (default "
       "0.02)",
       +[](O& o) -> double& { return o.bounds.outlier_fraction; }},
      {"min_depth_fraction", "--temporal-min-depth-fraction",
       "a still tile is bounded when this fraction of it had a depth (default 0.25)",
       +[](O& o) -> double& { return o.bounds.min_depth_fraction; }},
      {"fusion", "--temporal-fusion,!--no-temporal-fusion",
       "add the previous instant's fused evidence to each instant after the first where no "
       "camera's image changed (default: on for several instants without fusion masks)",
       +[](O& o) -> bool& { return o.fusion; }},
      {"fusion_decay", "--temporal-fusion-decay",
       "the previous instant's evidence weighted by this factor, (0, 1] (default 1)",
       +[](O& o) -> double& { return o.carry.decay; }},
      {"fusion_block_voxels", "--temporal-fusion-block",
       "blocks judged still or changed as a whole, voxels a side (default 8)",
       +[](O& o) -> int& { return o.carry.block_voxels; }},
      {"fusion_changed_fraction", "--temporal-fusion-changed-fraction",
       "a block changed when this fraction of the cameras that see it see a change, (0, 1] "
       "(default 0.5)",
       +[](O& o) -> double& { return o.carry.changed_fraction; }},
  };
  return fields;
}

const std::vector<SettingField<SilhouetteUse>>& SilhouetteSettingFields() {
  using O = SilhouetteUse;
  static const std::vector<SettingField<O>> fields = {
      {"volume", "!--no-volume-masks", "do not shrink the derived volume to the masks' visual hull",
       +[](O& o) -> bool& { return o.volume; }},
      {"stereo", "!--no-stereo-masks",
       "search every pixel over its whole range, not the foreground within the hull",
       +[](O& o) -> bool& { return o.stereo; }},
      {"fusion", "!--no-fusion-masks",
       "no free space where the masks say background (outside the hull)",
       +[](O& o) -> bool& { return o.fusion; }},
      {"hull_surface", "!--no-hull-surface",
       "no hull surface where no range image saw a voxel inside the hull (derived on for "
       "sparse rigs)",
       +[](O& o) -> bool& { return o.hull_surface; }},
      {"carve_votes", "--carve-votes",
       "cameras that must see a point as background to carve it from the hull (>= 1)",
       +[](O& o) -> int& { return o.carve_votes; }},
      {"min_views", "--min-views",
       "cameras that must see a point as foreground for it to be in the hull (>= 2)",
       +[](O& o) -> int& { return o.min_views; }},
      {"photo_carve", "!--no-photo-carve",
       "do not carve the hull where the cameras see its surface in inconsistent colours "
       "(derived on with the hull surface)",
       +[](O& o) -> bool& { return o.photo_carve; }},
  };
  return fields;
}

const std::vector<SettingField<CoarseToFineOptions>>& CoarseToFineSettingFields() {
  using O = CoarseToFineOptions;
  static const std::vector<SettingField<O>> fields = {
      {"coarse_factor", "", "image reduction of the coarse pass",
       +[](O& o) -> int& { return o.coarse_factor; }},
      {"coarse_window_px", "", "coarse SSD window side, coarse px",
       +[](O& o) -> int& { return o.coarse_window_px; }},
      {"tile_px", "", "fine pass tile side, px", +[](O& o) -> int& { return o.tile_px; }},
      {"margin_levels", "", "around a tile's coarse depths, coarse levels",
       +[](O& o) -> double& { return o.margin_levels; }},
      {"trim_fraction", "", "coarse depths dropped per end",
       +[](O& o) -> double& { return o.trim_fraction; }},
      {"min_coarse_depths", "", "tiles with fewer coarse depths are left without depth",
       +[](O& o) -> int& { return o.min_coarse_depths; }},
      {"coarse_min_uniqueness", "", "coarse pass uniqueness; 0: the fine pass's",
       +[](O& o) -> double& { return o.coarse_min_uniqueness; }},
      {"fill_min_neighbours", "", "searched neighbour tiles that fill a tile; 0: none",
       +[](O& o) -> int& { return o.fill_min_neighbours; }},
      {"clip_pad_mm", "", "added to each end of a clipped range, mm",
       +[](O& o) -> double& { return o.clip_pad_mm; }},
  };
  return fields;
}

const std::vector<SettingField<fusion::FusionOptions>>& FusionSettingFields() {
  using O = fusion::FusionOptions;
  static const std::vector<SettingField<O>> fields = {
      {"truncation_mm", "--truncation-mm",
       "untouched beyond this far behind the surface, mm (default 3 voxels)",
       +[](O& o) -> double& { return o.truncation_mm; }},
      {"front_clamp_mm", "--clamp-mm", "free-space contribution clamp, mm (default 3 voxels)",
       +[](O& o) -> double& { return o.front_clamp_mm; }},
      {"max_depth_jump_ratio", "--jump-ratio",
       "depth jump (fraction of depth) that breaks the tessellation",
       +[](O& o) -> double& { return o.max_depth_jump_ratio; }},
      {"min_depth_mm", "--min-depth-mm", "voxels nearer a camera are not updated by it, mm",
       +[](O& o) -> double& { return o.min_depth_mm; }},
      {"min_consistent_views", "--consistent-views",
       "fuse a depth sample only if this many other cameras agree (0: off)",
       +[](O& o) -> int& { return o.min_consistent_views; }},
      {"consistency_tolerance_mm", "--consistency-mm",
       "largest depth difference that agrees, mm (default 1 voxel)",
       +[](O& o) -> double& { return o.consistency_tolerance_mm; }},
      {"min_weight", "--min-weight",
       "voxels of less summed weight (images) are left unobserved (0: keep all)",
       +[](O& o) -> double& { return o.min_weight; }},
  };
  return fields;
}

namespace {

template <class Options>
void SetAll(const std::vector<SettingField<Options>>& fields, const Options& o,
            google::protobuf::Message* m) {
  for (const auto& f : fields) SetProtoField(f, o, m);
}

template <class Options>
void GetSet(const std::vector<SettingField<Options>>& fields, const google::protobuf::Message& m,
            Options* o) {
  for (const auto& f : fields) GetProtoField(f, m, o);
}

// Checks with `check`, placing its errors under `where`.
template <class Check>
void CheckUnder(const std::string& where, Check check) {
  try {
    check();
  } catch (const core::InputError& e) {
    throw e.Under(where);
  }
}

// Runs `read` (reading and checking one settings message), naming the field in its
// errors as the file that holds the message does, so that a flag and the file field
// it sets are refused with the same message: "where: <section><field>" (section
// "stereo." for the stereo settings in a session file, "" in a stereo options file).
// The errors come as "where: field" (read here) or "field" (an options Check());
// `own` is the prefix an options Check() puts before its fields ("fusion: "), dropped.
template <class Read>
auto NamedAsInFile(const std::string& where, const std::string& section, const std::string& own,
                   Read read) {
  try {
    return read();
  } catch (const core::InputError& e) {
    std::string field = e.where();
    const std::string message =
        std::string(e.what()).substr(field.empty() ? 0 : field.size() + 2);
    if (field.rfind(where + ": ", 0) == 0) field = field.substr(where.size() + 2);
    if (!own.empty() && field.rfind(own, 0) == 0) field = field.substr(own.size());
    throw core::InputError(where + ": " + section + field, message);
  }
}

}  // namespace

runtime::StereoSettings ToStereoSettings(const TakeStereoOptions& o) {
  runtime::StereoSettings s;
  SetAll(StereoSettingFields(), o, &s);
  if (o.coarse_to_fine) *s.mutable_coarse_to_fine() = ToCoarseToFineSettings(*o.coarse_to_fine);
  if (o.clip) {
    for (int i = 0; i < 3; ++i) {
      s.add_clip_min_mm(o.clip_min_mm[i]);
      s.add_clip_max_mm(o.clip_max_mm[i]);
    }
  }
  for (const auto& [id, z] : o.camera_depth_mm) {
    auto* r = s.add_camera_depths();
    r->set_camera(id);
    r->set_z_min_mm(z.first);
    r->set_z_max_mm(z.second);
  }
  return s;
}

TakeStereoOptions FromStereoSettings(const runtime::StereoSettings& s, const std::string& where,
                                     const TakeStereoOptions& base, const std::string& section) {
  return NamedAsInFile(where, section, "", [&] { return FromStereoSettings(s, where, base); });
}

TakeStereoOptions FromStereoSettings(const runtime::StereoSettings& s, const std::string& where,
                                     const TakeStereoOptions& base) {
  TakeStereoOptions o = base;
  GetSet(StereoSettingFields(), s, &o);
  if (s.has_coarse_to_fine())
    o.coarse_to_fine = FromCoarseToFineSettings(s.coarse_to_fine(), where);
  if (s.clip_min_mm_size() > 0 || s.clip_max_mm_size() > 0) {
    core::Require(s.clip_min_mm_size() == 3 && s.clip_max_mm_size() == 3, where + ": clip_min_mm",
                  "expected x y z (3 numbers, mm) in both clip_min_mm and clip_max_mm");
    o.clip = true;
    o.clip_min_mm = Eigen::Vector3d(s.clip_min_mm(0), s.clip_min_mm(1), s.clip_min_mm(2));
    o.clip_max_mm = Eigen::Vector3d(s.clip_max_mm(0), s.clip_max_mm(1), s.clip_max_mm(2));
  }
  for (const auto& r : s.camera_depths()) {
    core::Require(!o.camera_depth_mm.count(r.camera()), where + ": camera_depths",
                  "names camera '" + r.camera() + "' twice");
    o.camera_depth_mm[r.camera()] = {r.z_min_mm(), r.z_max_mm()};
  }
  CheckUnder(where, [&] { o.Check(); });
  return o;
}

TakeStereoOptions ParseStereoOptionsJson(const std::string& json, const std::string& where,
                                         const TakeStereoOptions& base) {
  runtime::StereoSettings s;
  schema::ParseJson(json, where, "not a stereo options object", &s);
  return FromStereoSettings(s, where, base);
}

TakeStereoOptions ReadStereoOptionsJson(const std::filesystem::path& path,
                                        const TakeStereoOptions& base) {
  return ParseStereoOptionsJson(io::ReadFileBytes(path), path.string(), base);
}

std::string StereoOptionsToJson(const TakeStereoOptions& o) {
  return schema::PrintJson(ToStereoSettings(o));
}

void SilhouetteUse::Check() const {
  core::Require(carve_votes >= 1, "silhouettes.carve_votes",
                "must be at least 1 camera, got " + std::to_string(carve_votes));
  core::Require(min_views >= 2, "silhouettes.min_views",
                "must be at least 2 cameras, got " + std::to_string(min_views));
}

runtime::SilhouetteSettings ToSilhouetteSettings(const SilhouetteUse& use) {
  runtime::SilhouetteSettings s;
  SetAll(SilhouetteSettingFields(), use, &s);
  return s;
}

SilhouetteUse FromSilhouetteSettings(const runtime::SilhouetteSettings& s) {
  SilhouetteUse use;
  GetSet(SilhouetteSettingFields(), s, &use);
  return use;
}

runtime::TemporalSettings ToTemporalSettings(const TemporalUse& use) {
  runtime::TemporalSettings s;
  SetAll(TemporalSettingFields(), use, &s);
  return s;
}

TemporalUse FromTemporalSettings(const runtime::TemporalSettings& s, const std::string& where) {
  TemporalUse use;
  GetSet(TemporalSettingFields(), s, &use);
  CheckUnder(where, [&] { use.Check(); });
  return use;
}

runtime::CoarseToFineSettings ToCoarseToFineSettings(const CoarseToFineOptions& o) {
  runtime::CoarseToFineSettings s;
  SetAll(CoarseToFineSettingFields(), o, &s);
  if (o.clip) {
    for (int i = 0; i < 3; ++i) {
      s.add_clip_min_mm(o.clip_min_mm[i]);
      s.add_clip_max_mm(o.clip_max_mm[i]);
    }
  }
  return s;
}

CoarseToFineOptions FromCoarseToFineSettings(const runtime::CoarseToFineSettings& s,
                                             const std::string& where) {
  CoarseToFineOptions o;
  GetSet(CoarseToFineSettingFields(), s, &o);
  o.clip = s.clip_min_mm_size() > 0 || s.clip_max_mm_size() > 0;
  core::Require(!o.clip || s.clip_min_mm_size() == 3, where + ": coarse_to_fine.clip_min_mm",
                "expected x y z (3 numbers, mm) with clip_max_mm, got " +
                    std::to_string(s.clip_min_mm_size()));
  core::Require(!o.clip || s.clip_max_mm_size() == 3, where + ": coarse_to_fine.clip_max_mm",
                "expected x y z (3 numbers, mm) with clip_min_mm, got " +
                    std::to_string(s.clip_max_mm_size()));
  for (int i = 0; o.clip && i < 3; ++i) {
    o.clip_min_mm[i] = s.clip_min_mm(i);
    o.clip_max_mm[i] = s.clip_max_mm(i);
  }
  CheckUnder(where, [&] { o.Check(); });
  return o;
}

runtime::Volume ToVolume(const fusion::VolumeGrid& g) {
  runtime::Volume v;
  for (int a = 0; a < 3; ++a) v.add_origin_mm(g.origin_mm[a]);
  v.set_voxel_size_mm(g.voxel_size_mm);
  v.add_dims(g.nx);
  v.add_dims(g.ny);
  v.add_dims(g.nz);
  return v;
}

fusion::VolumeGrid FromVolume(const runtime::Volume& v, const std::string& where) {
  const double voxel_mm = v.has_voxel_size_mm() ? v.voxel_size_mm() : kDefaultVoxelMm;
  core::Require(std::isfinite(voxel_mm) && voxel_mm > 0, where + ": volume.voxel_size_mm",
                "must be a positive number of mm, got " + std::to_string(voxel_mm));
  fusion::VolumeGrid g = DefaultVolume(voxel_mm);
  core::Require(v.dims_size() > 0 || g.nx > 0, where + ": volume.voxel_size_mm",
                std::to_string(voxel_mm) + " mm makes " +
                    std::to_string(std::round(kSeedCubeMm / voxel_mm)) +
                    " voxels along an axis of the seed's 6000 mm cube (at most 1048576)");
  if (v.origin_mm_size() > 0) {
    core::Require(v.origin_mm_size() == 3, where + ": volume.origin_mm",
                  "expected 3 values (x y z, mm), got " + std::to_string(v.origin_mm_size()));
    g.origin_mm = Eigen::Vector3d(v.origin_mm(0), v.origin_mm(1), v.origin_mm(2));
  }
  if (v.dims_size() > 0) {
    core::Require(v.dims_size() == 3, where + ": volume.dims",
                  "expected 3 counts (x y z), got " + std::to_string(v.dims_size()));
    g.nx = v.dims(0);
    g.ny = v.dims(1);
    g.nz = v.dims(2);
  }
  g.Check(where + ": volume");
  return g;
}

runtime::FusionSettings ToFusionSettings(const fusion::FusionOptions& o) {
  runtime::FusionSettings s;
  SetAll(FusionSettingFields(), o, &s);
  return s;
}

fusion::FusionOptions FromFusionSettings(const runtime::FusionSettings& s, double voxel_size_mm,
                                         const std::string& where) {
  fusion::FusionOptions o = DefaultFusionOptions(voxel_size_mm);
  GetSet(FusionSettingFields(), s, &o);
  // The settings are the `fusion` field of a session or a fusion job: its fields are
  // named as there ("session: fusion.truncation_mm").
  NamedAsInFile(where, "fusion.", "fusion: ", [&] {
    o.Check();
    return 0;
  });
  return o;
}

}  // namespace dome::pipeline
