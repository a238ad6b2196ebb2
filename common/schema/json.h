// Protobuf's JSON mapping, the one way dome reads and writes the files whose schema is a
// proto/ message: TAKE/rig.json (rig.proto), TAKE/calib/*.json (calib.proto), SESSION.json
// and stereo options (runtime.proto). Field names are the proto's ("z_min_mm", or
// lowerCamelCase on input); unknown fields are errors that name the field.
#pragma once

#include <google/protobuf/message.h>

#include <string>

namespace dome::schema {

// Parses `json` into `message`. Throws core::InputError(where, "<what>: <protobuf's
// reason>") on bad JSON, an unknown field or a value of the wrong type (protobuf's
// reason names the field: "Cannot find field: zmin").
void ParseJson(const std::string& json, const std::string& where, const std::string& what,
               google::protobuf::Message* message);

// `message` as JSON with the proto field names, every field written (defaults too),
// indented.
std::string PrintJson(const google::protobuf::Message& message);

}  // namespace dome::schema
