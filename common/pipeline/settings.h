// The stages' options as the wire and the files carry them (proto/runtime.proto
// StereoSettings, CoarseToFineSettings, FusionSettings, Volume): one table a struct,
// each row binding an options field to its proto field (by name) and to the command-line
// flag that sets it, so that an option is written once, here, besides its struct and its
// proto field. The conversions, the JSON files and the flags of `dome stereo`,
// `dome fuse` and `dome run` (cli/setting_flags.h) all go through these tables.
//
// Conversions apply only the proto fields that are set, over a base (the library
// defaults or a profile), then check the result; errors name "<where>: <field>".
// Stereo options JSON (`dome stereo --options FILE`, a session file's "stereo" object)
// is the protobuf JSON of StereoSettings, e.g.
//   {"z_min_mm": 750, "z_max_mm": 5000, "window_sizes_px": [5, 9, 13],
//    "min_uniqueness": 0.5, "normalize_contrast": true, "max_neighbours": 2,
//    "coarse_to_fine": {"tile_px": 64, "clip_min_mm": [-50, -50, 0],
//                       "clip_max_mm": [50, 50, 80]}}
#pragma once

#include <google/protobuf/message.h>

#include <filesystem>
#include <string>
#include <variant>
#include <vector>

#include "fusion/integrate.h"
#include "fusion/temporal_carry.h"
#include "fusion/volume.h"
#include "runtime.pb.h"
#include "stereo/take_stereo.h"
#include "stereo/temporal_bounds.h"

namespace dome::pipeline {

// One option: its proto field, its flag ("" = none; "!--x": a flag that sets a bool
// false) and help text with the unit, and where it lives in `Options`.
template <class Options>
struct SettingField {
  const char* proto_name;
  const char* flag;
  const char* help;
  std::variant<double& (*)(Options&), int& (*)(Options&), bool& (*)(Options&),
               std::vector<int>& (*)(Options&)>
      member;
};

// Which uses of the take's foreground masks are on (proto SilhouetteSettings): the
// volume (pipeline/derive.h), stereo's search (stereo/search_bounds.h) and fusion
// (fusion/hull_fusion.h). All off: the reconstruction without masks, bit for bit.
struct SilhouetteUse {
  bool volume = false;
  bool stereo = false;
  bool fusion = false;
  // How the hull is used where it is (fusion/hull_fusion.h fill_unseen,
  // silhouette/hull.h carve_votes and min_views); derived from the rig (pipeline/derive.h).
  bool hull_surface = false;
  int carve_votes = 2;
  int min_views = 2;  // silhouette/hull.h min_views; derived from the rig
  // The hull carved by photo-consistency (silhouette/photo_hull.h) where it is used in
  // fusion; derived: with hull_surface.
  bool photo_carve = false;
  bool Any() const { return volume || stereo || fusion; }
  // Throws core::InputError naming the field when out of range.
  void Check() const;
};

// Time-aware reconstruction (proto TemporalSettings): an instant's stereo searches
// around the previous instant's depths where its images are still
// (stereo/temporal_bounds.h), and its fusion adds the previous instant's fused evidence
// there (fusion/temporal_carry.h; the change rule is the bounds'). Off: each instant on
// its own, bit for bit.
struct TemporalUse {
  bool stereo = false;
  bool fusion = false;
  stereo::TemporalBoundsOptions bounds;
  fusion::TemporalCarryOptions carry;
  bool Any() const { return stereo || fusion; }
  // Throws core::InputError naming the field ("temporal.tile_px").
  void Check() const {
    bounds.Check();
    carry.Check();
  }
};

const std::vector<SettingField<stereo::TakeStereoOptions>>& StereoSettingFields();
const std::vector<SettingField<TemporalUse>>& TemporalSettingFields();
const std::vector<SettingField<SilhouetteUse>>& SilhouetteSettingFields();
const std::vector<SettingField<stereo::CoarseToFineOptions>>& CoarseToFineSettingFields();
const std::vector<SettingField<fusion::FusionOptions>>& FusionSettingFields();

// Sets `message`'s field of `field` from `options` (repeated fields replaced).
template <class Options>
void SetProtoField(const SettingField<Options>& field, const Options& options,
                   google::protobuf::Message* message);
// Applies `message`'s field of `field` to `options` when it is set (a repeated field:
// when not empty); true when it was.
template <class Options>
bool GetProtoField(const SettingField<Options>& field, const google::protobuf::Message& message,
                   Options* options);

// Stereo options <-> StereoSettings (every field set, coarse_to_fine when present).
runtime::StereoSettings ToStereoSettings(const stereo::TakeStereoOptions& options);
stereo::TakeStereoOptions FromStereoSettings(const runtime::StereoSettings& settings,
                                             const std::string& where,
                                             const stereo::TakeStereoOptions& base = {});
// The same, for settings that are the field `section` of a message (a session's
// "stereo."): errors name the field by its path there, "where: stereo.num_levels", as
// the session file does.
stereo::TakeStereoOptions FromStereoSettings(const runtime::StereoSettings& settings,
                                             const std::string& where,
                                             const stereo::TakeStereoOptions& base,
                                             const std::string& section);
// The stereo options JSON above, over `base`; errors name the source and the field.
stereo::TakeStereoOptions ParseStereoOptionsJson(const std::string& json, const std::string& where,
                                                 const stereo::TakeStereoOptions& base = {});
stereo::TakeStereoOptions ReadStereoOptionsJson(const std::filesystem::path& path,
                                                const stereo::TakeStereoOptions& base = {});
// The JSON of `options` (every field written), parseable by ParseStereoOptionsJson.
std::string StereoOptionsToJson(const stereo::TakeStereoOptions& options);

// Silhouette uses <-> SilhouetteSettings (unset fields: off).
runtime::SilhouetteSettings ToSilhouetteSettings(const SilhouetteUse& use);
SilhouetteUse FromSilhouetteSettings(const runtime::SilhouetteSettings& settings);

// Temporal use <-> TemporalSettings (every field set; unset fields: the defaults, stereo
// off); errors name "where: temporal.<field>".
runtime::TemporalSettings ToTemporalSettings(const TemporalUse& use);
TemporalUse FromTemporalSettings(const runtime::TemporalSettings& settings,
                                 const std::string& where);

// Coarse to fine <-> CoarseToFineSettings; the clip box is set when both corners are.
runtime::CoarseToFineSettings ToCoarseToFineSettings(const stereo::CoarseToFineOptions& options);
stereo::CoarseToFineOptions FromCoarseToFineSettings(const runtime::CoarseToFineSettings& settings,
                                                     const std::string& where);

// The volume <-> Volume: unset fields take the derived defaults (pipeline/defaults.h).
runtime::Volume ToVolume(const fusion::VolumeGrid& grid);
fusion::VolumeGrid FromVolume(const runtime::Volume& volume, const std::string& where);
// Fusion options <-> FusionSettings: unset fields take the derived defaults for
// `voxel_size_mm` (pipeline/defaults.h). Errors name a field as the `fusion` field of
// a session or job holds it: "where: fusion.truncation_mm".
runtime::FusionSettings ToFusionSettings(const fusion::FusionOptions& options);
fusion::FusionOptions FromFusionSettings(const runtime::FusionSettings& settings,
                                         double voxel_size_mm, const std::string& where);

// ---- template definitions ------------------------------------------------------------

template <class Options>
void SetProtoField(const SettingField<Options>& field, const Options& options,
                   google::protobuf::Message* message) {
  const auto* f = message->GetDescriptor()->FindFieldByName(field.proto_name);
  const auto* r = message->GetReflection();
  Options& o = const_cast<Options&>(options);  // the accessors give references; only read
  std::visit(
      [&](auto member) {
        using T = std::decay_t<decltype(member(o))>;
        if constexpr (std::is_same_v<T, double>) {
          r->SetDouble(message, f, member(o));
        } else if constexpr (std::is_same_v<T, int>) {
          r->SetInt32(message, f, member(o));
        } else if constexpr (std::is_same_v<T, bool>) {
          r->SetBool(message, f, member(o));
        } else {
          r->ClearField(message, f);
          for (int v : member(o)) r->AddInt32(message, f, v);
        }
      },
      field.member);
}

template <class Options>
bool GetProtoField(const SettingField<Options>& field, const google::protobuf::Message& message,
                   Options* options) {
  const auto* f = message.GetDescriptor()->FindFieldByName(field.proto_name);
  const auto* r = message.GetReflection();
  if (f->is_repeated() ? r->FieldSize(message, f) == 0 : !r->HasField(message, f)) return false;
  std::visit(
      [&](auto member) {
        using T = std::decay_t<decltype(member(*options))>;
        if constexpr (std::is_same_v<T, double>) {
          member(*options) = r->GetDouble(message, f);
        } else if constexpr (std::is_same_v<T, int>) {
          member(*options) = r->GetInt32(message, f);
        } else if constexpr (std::is_same_v<T, bool>) {
          member(*options) = r->GetBool(message, f);
        } else {
          auto& values = member(*options);
          values.clear();
          for (int i = 0; i < r->FieldSize(message, f); ++i)
            values.push_back(r->GetRepeatedInt32(message, f, i));
        }
      },
      field.member);
  return true;
}

}  // namespace dome::pipeline
