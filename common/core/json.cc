#include "core/json.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace dome::core {
namespace {

std::string Leaf(const Json& j) {
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

void Print(const Json& j, std::string& out) {
  if (j.is_object()) {
    out += '{';
    bool first = true;
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (!first) out += ", ";
      first = false;
      out += Leaf(Json(it.key()));
      out += ": ";
      Print(it.value(), out);
    }
    out += '}';
  } else if (j.is_array()) {
    out += '[';
    for (size_t i = 0; i < j.size(); ++i) {
      if (i) out += ", ";
      Print(j[i], out);
    }
    out += ']';
  } else {
    out += Leaf(j);
  }
}

}  // namespace

std::string DumpJson(const Json& j, int indent) {
  if (indent >= 0) return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
  std::string out;
  Print(j, out);
  return out;
}

void PrintJsonLine(const Json& j) {
  const std::string line = DumpJson(j) + "\n";
  std::fwrite(line.data(), 1, line.size(), stdout);
  std::fflush(stdout);
}

Json FloatJson(float value) {
  if (!std::isfinite(value)) return Json();
  if (value == std::trunc(value) && std::fabs(value) < 1e9f) return Json(int64_t(value));
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", double(value));
  return Json(std::strtod(buf, nullptr));
}

}  // namespace dome::core
