#include "stereo/options_json.h"

#include <google/protobuf/util/json_util.h>

#include <string>

#include "core/error.h"
#include "io/file_util.h"
#include "runtime.pb.h"

namespace dome::stereo {

runtime::StereoSettings ToStereoSettings(const TakeStereoOptions& o) {
  runtime::StereoSettings s;
  s.set_z_min_mm(o.stereo.z_min_mm);
  s.set_z_max_mm(o.stereo.z_max_mm);
  s.set_num_levels(o.stereo.num_levels);
  s.set_level_step_px(o.stereo.level_step_px);
  for (int w : o.stereo.window_sizes_px) s.add_window_sizes_px(w);
  s.set_normalize_contrast(o.stereo.normalize_contrast);
  s.set_sqrt_greys(o.stereo.sqrt_greys);
  s.set_outside_difference_grey(o.stereo.outside_difference_grey);
  s.set_min_curvature(o.stereo.min_curvature);
  s.set_min_uniqueness(o.stereo.min_uniqueness);
  s.set_min_texture_grey(o.stereo.min_texture_grey);
  s.set_max_neighbours(o.cluster.max_neighbours);
  s.set_max_axis_angle_deg(o.cluster.max_axis_angle_deg);
  s.set_prewarp_neighbours(o.stereo.prewarp_neighbours);
  s.set_speckle_area_px(o.stereo.speckle.min_area_px);
  s.set_speckle_step_mm(o.stereo.speckle.max_step_mm);
  if (o.coarse_to_fine) *s.mutable_coarse_to_fine() = *o.coarse_to_fine;
  return s;
}

TakeStereoOptions FromStereoSettings(const runtime::StereoSettings& s, const std::string& where,
                                     const TakeStereoOptions& base) {
  TakeStereoOptions o = base;
  auto& st = o.stereo;
  if (s.has_z_min_mm()) st.z_min_mm = s.z_min_mm();
  if (s.has_z_max_mm()) st.z_max_mm = s.z_max_mm();
  if (s.has_num_levels()) st.num_levels = s.num_levels();
  if (s.has_level_step_px()) st.level_step_px = s.level_step_px();
  if (s.window_sizes_px_size() > 0) {
    st.window_sizes_px.assign(s.window_sizes_px().begin(), s.window_sizes_px().end());
  }
  if (s.has_normalize_contrast()) st.normalize_contrast = s.normalize_contrast();
  if (s.has_sqrt_greys()) st.sqrt_greys = s.sqrt_greys();
  if (s.has_outside_difference_grey()) st.outside_difference_grey = s.outside_difference_grey();
  if (s.has_min_curvature()) st.min_curvature = s.min_curvature();
  if (s.has_min_uniqueness()) st.min_uniqueness = s.min_uniqueness();
  if (s.has_min_texture_grey()) st.min_texture_grey = s.min_texture_grey();
  if (s.has_max_neighbours()) o.cluster.max_neighbours = s.max_neighbours();
  if (s.has_max_axis_angle_deg()) o.cluster.max_axis_angle_deg = s.max_axis_angle_deg();
  if (s.has_prewarp_neighbours()) st.prewarp_neighbours = s.prewarp_neighbours();
  if (s.has_speckle_area_px()) st.speckle.min_area_px = s.speckle_area_px();
  if (s.has_speckle_step_mm()) st.speckle.max_step_mm = s.speckle_step_mm();
  if (s.has_coarse_to_fine()) o.coarse_to_fine = s.coarse_to_fine();
  try {
    o.Check();
  } catch (const core::InputError& e) {
    throw e.Under(where);
  }
  return o;
}

TakeStereoOptions ParseStereoOptionsJson(const std::string& json, const std::string& where,
                                         const TakeStereoOptions& base) {
  runtime::StereoSettings s;
  google::protobuf::util::JsonParseOptions parse;
  parse.ignore_unknown_fields = false;
  const auto status = google::protobuf::util::JsonStringToMessage(json, &s, parse);
  // Protobuf's message names the field ("Cannot find field: zmin", "Invalid value for
  // int32 field num_levels").
  core::Require(status.ok(), where,
                "not a stereo options object (" + std::string(status.message()) + ")");
  return FromStereoSettings(s, where, base);
}

TakeStereoOptions ReadStereoOptionsJson(const std::filesystem::path& path,
                                        const TakeStereoOptions& base) {
  return ParseStereoOptionsJson(io::ReadFileBytes(path), path.string(), base);
}

std::string StereoOptionsToJson(const TakeStereoOptions& o) {
  const runtime::StereoSettings s = ToStereoSettings(o);
  google::protobuf::util::JsonPrintOptions print;
  print.add_whitespace = true;
  print.preserve_proto_field_names = true;
  std::string json;
  const auto status = google::protobuf::util::MessageToJsonString(s, &json, print);
  if (!status.ok()) throw std::runtime_error("stereo options to JSON: " + status.ToString());
  return json;
}

}  // namespace dome::stereo
