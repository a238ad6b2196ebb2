// The JSON form of the stereo options (`dome stereo --options FILE`).
//
// The schema is the protobuf JSON mapping of dome.runtime.StereoSettings
// (proto/runtime.proto): the same object a session file holds under "stereo", so one
// file serves both. Field names as in the proto ("z_min_mm") or lowerCamelCase
// ("zMinMm"); units as in StereoOptions / ClusterOptions:
//
//   {"z_min_mm": 750, "z_max_mm": 5000, "window_sizes_px": [5, 9, 13],
//    "min_uniqueness": 0.5, "normalize_contrast": true, "max_neighbours": 2}
//
// Fields left out keep the values of `base`. Unknown fields, values of the wrong type
// and values out of range are errors that name the file and the field.
#pragma once

#include <filesystem>
#include <string>

#include "runtime.pb.h"
#include "stereo/take_stereo.h"

namespace dome::stereo {

// Parses `json` over `base`. `where` names the source in errors (e.g. the file).
// Throws core::InputError("<where>: <field>", ...) on bad input.
TakeStereoOptions ParseStereoOptionsJson(const std::string& json, const std::string& where,
                                         const TakeStereoOptions& base = {});

// Reads and parses a file (errors name the path).
TakeStereoOptions ReadStereoOptionsJson(const std::filesystem::path& path,
                                        const TakeStereoOptions& base = {});

// The protobuf form jobs and session files carry. FromStereoSettings applies the fields
// that are set over `base` and checks the result (errors "<where>: <field>").
runtime::StereoSettings ToStereoSettings(const TakeStereoOptions& options);
TakeStereoOptions FromStereoSettings(const runtime::StereoSettings& settings,
                                     const std::string& where, const TakeStereoOptions& base = {});

// The JSON of `options` (every field written), parseable by ParseStereoOptionsJson.
std::string StereoOptionsToJson(const TakeStereoOptions& options);

}  // namespace dome::stereo
