#include "pipeline/session.h"

#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "io/file_util.h"

namespace dome::pipeline {

void SessionOptions::Check() const {
  stereo.Check();
  grid.Check("session: volume");
  fusion.Check();
  core::Require(slab_planes > 0, "session: slab_planes",
                "must be positive, got " + std::to_string(slab_planes));
  core::Require(decimate_ratio > 0 && decimate_ratio <= 1, "session: decimate_ratio",
                "must be in (0, 1], got " + std::to_string(decimate_ratio));
  try {
    smooth.Check();
  } catch (const core::InputError& e) {
    throw e.Under("session");
  }
}

runtime::Session ReadSessionJson(const std::filesystem::path& path) {
  const std::string text = io::ReadFileBytes(path);
  runtime::Session session;
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  const auto status = google::protobuf::util::JsonStringToMessage(text, &session, options);
  if (!status.ok()) {
    throw core::InputError(path.string(), "not a session (" + std::string(status.message()) + ")");
  }
  return session;
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
  fusion::VolumeGrid g;
  if (v.has_voxel_size_mm()) g.voxel_size_mm = v.voxel_size_mm();
  core::Require(std::isfinite(g.voxel_size_mm) && g.voxel_size_mm > 0,
                where + ": volume.voxel_size_mm", "must be positive");
  g.nx = g.ny = g.nz = int(std::lround(6000.0 / g.voxel_size_mm));
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
  s.set_truncation_mm(o.truncation_mm);
  s.set_front_clamp_mm(o.front_clamp_mm);
  s.set_max_depth_jump_ratio(o.max_depth_jump_ratio);
  s.set_min_depth_mm(o.min_depth_mm);
  s.set_min_consistent_views(o.min_consistent_views);
  s.set_consistency_tolerance_mm(o.consistency_tolerance_mm);
  s.set_min_weight(o.min_weight);
  return s;
}

fusion::FusionOptions FromFusionSettings(const runtime::FusionSettings& s, double voxel_size_mm,
                                         const std::string& where) {
  fusion::FusionOptions o;
  o.truncation_mm = s.has_truncation_mm() ? s.truncation_mm() : 3 * voxel_size_mm;
  o.front_clamp_mm = s.has_front_clamp_mm() ? s.front_clamp_mm() : 3 * voxel_size_mm;
  if (s.has_max_depth_jump_ratio()) o.max_depth_jump_ratio = s.max_depth_jump_ratio();
  if (s.has_min_depth_mm()) o.min_depth_mm = s.min_depth_mm();
  if (s.has_min_consistent_views()) o.min_consistent_views = s.min_consistent_views();
  o.consistency_tolerance_mm =
      s.has_consistency_tolerance_mm() ? s.consistency_tolerance_mm() : voxel_size_mm;
  if (s.has_min_weight()) o.min_weight = s.min_weight();
  try {
    o.Check();
  } catch (const core::InputError& e) {
    throw core::InputError(where + ": fusion", e.what());
  }
  return o;
}

SessionOptions ResolveSessionOptions(const runtime::Session& s, const std::string& where) {
  SessionOptions o;
  o.stereo = stereo::FromStereoSettings(s.stereo(), where);
  if (o.stereo.coarse_to_fine) FromCoarseToFineSettings(*o.stereo.coarse_to_fine, where);
  o.stereo.write_previews = s.has_write_previews() ? s.write_previews() : true;
  o.grid = FromVolume(s.volume(), where);
  o.fusion = FromFusionSettings(s.fusion(), o.grid.voxel_size_mm, where);
  if (s.has_slab_planes()) o.slab_planes = s.slab_planes();
  if (s.has_decimate_ratio()) o.decimate_ratio = s.decimate_ratio();
  if (s.has_texture()) o.texture = s.texture();
  if (s.has_smooth_iterations()) o.smooth.iterations = s.smooth_iterations();
  if (s.has_smooth_lambda()) o.smooth.lambda = s.smooth_lambda();
  if (s.has_smooth_mu()) o.smooth.mu = s.smooth_mu();
  try {
    o.smooth.Check();
  } catch (const core::InputError& e) {
    throw e.Under(where);
  }
  core::Require(o.slab_planes > 0, where + ": slab_planes",
                "must be positive, got " + std::to_string(o.slab_planes));
  core::Require(o.decimate_ratio > 0 && o.decimate_ratio <= 1, where + ": decimate_ratio",
                "must be in (0, 1]");
  return o;
}

CoarseToFineOptions FromCoarseToFineSettings(const runtime::CoarseToFineSettings& s,
                                             const std::string& where) {
  CoarseToFineOptions o;
  if (s.has_coarse_factor()) o.coarse_factor = s.coarse_factor();
  if (s.has_coarse_window_px()) o.coarse_window_px = s.coarse_window_px();
  if (s.has_tile_px()) o.tile_px = s.tile_px();
  if (s.has_margin_levels()) o.margin_levels = s.margin_levels();
  if (s.has_trim_fraction()) o.trim_fraction = s.trim_fraction();
  if (s.has_min_coarse_depths()) o.min_coarse_depths = s.min_coarse_depths();
  if (s.has_coarse_min_uniqueness()) o.coarse_min_uniqueness = s.coarse_min_uniqueness();
  if (s.has_fill_min_neighbours()) o.fill_min_neighbours = s.fill_min_neighbours();
  try {
    o.Check();
  } catch (const core::InputError& e) {
    throw e.Under(where);
  }
  const bool has_box = s.clip_min_mm_size() > 0 || s.clip_max_mm_size() > 0;
  core::Require(!has_box || s.clip_min_mm_size() == 3, where + ": coarse_to_fine.clip_min_mm",
                "expected x y z (3 numbers, mm) with clip_max_mm, got " +
                    std::to_string(s.clip_min_mm_size()));
  core::Require(!has_box || s.clip_max_mm_size() == 3, where + ": coarse_to_fine.clip_max_mm",
                "expected x y z (3 numbers, mm) with clip_min_mm, got " +
                    std::to_string(s.clip_max_mm_size()));
  for (int i = 0; has_box && i < 3; ++i) {
    core::Require(std::isfinite(s.clip_min_mm(i)) && std::isfinite(s.clip_max_mm(i)) &&
                      s.clip_min_mm(i) < s.clip_max_mm(i),
                  where + ": coarse_to_fine.clip_max_mm",
                  "each coordinate must exceed clip_min_mm's, got " +
                      std::to_string(s.clip_max_mm(i)) + " <= " + std::to_string(s.clip_min_mm(i)) +
                      " (axis " + std::to_string(i) + ")");
  }
  core::Require(!s.has_clip_pad_mm() || (std::isfinite(s.clip_pad_mm()) && s.clip_pad_mm() >= 0),
                where + ": coarse_to_fine.clip_pad_mm",
                "must be >= 0 mm, got " + std::to_string(s.clip_pad_mm()));
  return o;
}

void ClipDepthRange(const runtime::CoarseToFineSettings& s, const geometry::TsaiCamera& camera,
                    const std::string& where, stereo::StereoOptions* o) {
  if (s.clip_min_mm_size() != 3 || s.clip_max_mm_size() != 3) return;
  const double pad = s.has_clip_pad_mm() ? s.clip_pad_mm() : 2.0;
  double z_lo = std::numeric_limits<double>::infinity();
  double z_hi = -std::numeric_limits<double>::infinity();
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3d p(c & 1 ? s.clip_max_mm(0) : s.clip_min_mm(0),
                            c & 2 ? s.clip_max_mm(1) : s.clip_min_mm(1),
                            c & 4 ? s.clip_max_mm(2) : s.clip_min_mm(2));
    const double z = camera.WorldToCamera(p).z();
    z_lo = std::min(z_lo, z);
    z_hi = std::max(z_hi, z);
  }
  const double z_min = std::max(o->z_min_mm, z_lo - pad);
  const double z_max = std::min(o->z_max_mm, z_hi + pad);
  core::Require(z_min < z_max, where + ": coarse_to_fine.clip_min_mm",
                "camera '" + camera.id + "' sees no depth of the clip box within [" +
                    std::to_string(o->z_min_mm) + ", " + std::to_string(o->z_max_mm) + "] mm");
  o->z_min_mm = z_min;
  o->z_max_mm = z_max;
}

std::vector<std::string> SessionInstants(const runtime::Session& session, const take::Take& take) {
  if (session.instants_size() == 0) return take.instants;
  std::vector<std::string> out;
  for (const std::string& instant : session.instants()) {
    core::Require(
        std::find(take.instants.begin(), take.instants.end(), instant) != take.instants.end(),
        "session: instants", "no instant '" + instant + "' in " + take.dir.string());
    if (std::find(out.begin(), out.end(), instant) == out.end()) out.push_back(instant);
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace dome::pipeline
