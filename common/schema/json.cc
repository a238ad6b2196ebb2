#include "schema/json.h"

#include <google/protobuf/util/json_util.h>

#include "core/error.h"

namespace dome::schema {

void ParseJson(const std::string& json, const std::string& where, const std::string& what,
               google::protobuf::Message* message) {
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  const auto status = google::protobuf::util::JsonStringToMessage(json, message, options);
  if (!status.ok()) throw core::InputError(where, what + ": " + std::string(status.message()));
}

std::string PrintJson(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  std::string json;
  const auto status = google::protobuf::util::MessageToJsonString(message, &json, options);
  DOME_CHECK(status.ok(), "cannot print JSON: " + status.ToString());
  return json;
}

}  // namespace dome::schema
