#include "geometry/middlebury.h"

#include <cmath>
#include <set>

#include "core/error.h"
#include "geometry/parse_util.h"

namespace dome::geometry {
namespace {

using internal::FormatDouble;
using internal::ParseDouble;
using internal::Where;

// Field names of a camera line after the image name, in file order.
std::string FieldName(int index) {
  static const char* const kNames[] = {"k11", "k12", "k13", "k21", "k22", "k23", "k31",
                                       "k32", "k33", "r11", "r12", "r13", "r21", "r22",
                                       "r23", "r31", "r32", "r33", "t1",  "t2",  "t3"};
  return kNames[index];
}

bool HasWhitespace(const std::string& text) {
  return text.find_first_of(" \t\r\n\v\f") != std::string::npos;
}

}  // namespace

void MiddleburyReadOptions::Check() const {
  core::Require(width_px > 0, "MiddleburyReadOptions.width_px",
                "must be positive (the par file does not store the image size), got " +
                    std::to_string(width_px));
  core::Require(height_px > 0, "MiddleburyReadOptions.height_px",
                "must be positive (the par file does not store the image size), got " +
                    std::to_string(height_px));
  core::Require(std::isfinite(mm_per_unit) && mm_per_unit > 0.0,
                "MiddleburyReadOptions.mm_per_unit",
                "must be positive and finite, got " + FormatDouble(mm_per_unit));
  pinhole.Check();
}

std::vector<TsaiCamera> ReadMiddleburyPar(const std::string& path,
                                          const MiddleburyReadOptions& options) {
  options.Check();
  const std::vector<std::string> lines = internal::SplitLines(internal::ReadTextFile(path));
  size_t next = 0;
  auto next_content_line = [&]() -> int {  // index of the next non-blank line, or -1
    while (next < lines.size() && internal::Trim(lines[next]).empty()) {
      ++next;
    }
    return next < lines.size() ? static_cast<int>(next++) : -1;
  };

  const int count_line = next_content_line();
  core::Require(count_line >= 0, path, "empty file: expected the number of images on line 1");
  const int count = internal::ParseInt(lines[count_line], Where(path, "line 1 (image count)"));
  core::Require(count >= 0, Where(path, "line 1 (image count)"),
                "must not be negative, got " + std::to_string(count));

  std::vector<TsaiCamera> cameras;
  std::set<std::string> names;
  for (int i = 0; i < count; ++i) {
    const int line_index = next_content_line();
    core::Require(line_index >= 0, path,
                  "the file announces " + std::to_string(count) + " images but has only " +
                      std::to_string(i) + " camera lines");
    const std::vector<std::string> tokens = internal::SplitWhitespace(lines[line_index]);
    const std::string line_where = Where(path, "line " + std::to_string(line_index + 1));
    core::Require(tokens.size() == 22, line_where,
                  "expected 22 fields (imgname k11..k33 r11..r33 t1 t2 t3), got " +
                      std::to_string(tokens.size()));
    const std::string& name = tokens[0];
    const std::string where = std::string(line_where).append(" (").append(name).append(")");
    core::Require(names.insert(name).second, where, "image name appears twice");
    double v[21];
    const std::string field_where = where + ": ";
    for (int k = 0; k < 21; ++k) {
      v[k] = ParseDouble(tokens[k + 1], field_where + FieldName(k));
    }

    PinholeCamera pinhole;
    pinhole.id = name;
    pinhole.width_px = options.width_px;
    pinhole.height_px = options.height_px;
    pinhole.K << v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8];
    Eigen::Matrix3d r;
    r << v[9], v[10], v[11], v[12], v[13], v[14], v[15], v[16], v[17];
    pinhole.rotation = internal::RequireNearRotation(r, 1e-6, where + ": r11..r33");
    pinhole.translation_mm = Eigen::Vector3d(v[18], v[19], v[20]) * options.mm_per_unit;
    pinhole.Check(where);
    cameras.push_back(TsaiFromPinhole(pinhole, options.pinhole));
  }
  const int extra = next_content_line();
  core::Require(
      extra < 0, Where(path, "line " + std::to_string(extra + 1)),
      "the file announces " + std::to_string(count) + " images but has more camera lines");
  return cameras;
}

void WriteMiddleburyPar(const std::string& path, const std::vector<TsaiCamera>& cameras,
                        double mm_per_unit) {
  core::Require(std::isfinite(mm_per_unit) && mm_per_unit > 0.0, Where(path, "mm_per_unit"),
                "must be positive and finite, got " + FormatDouble(mm_per_unit));
  std::string text = std::to_string(cameras.size()) + "\n";
  std::set<std::string> names;
  for (const TsaiCamera& camera : cameras) {
    const std::string where = Where(path, "camera '" + camera.id + "'");
    camera.Check(where);
    core::Require(!camera.id.empty() && !HasWhitespace(camera.id), where,
                  "the id is the image name: must be non-empty without white space");
    core::Require(names.insert(camera.id).second, where, "id appears twice");
    core::Require(camera.kappa1_per_mm2 == 0.0, where,
                  "kappa1 = " + FormatDouble(camera.kappa1_per_mm2) +
                      ": the Middlebury format has no distortion; undistort first");
    const Eigen::Matrix3d k = camera.K();
    const Eigen::Vector3d t = camera.translation_mm / mm_per_unit;
    text += camera.id;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        text += " " + FormatDouble(k(i, j));
      }
    }
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        text += " " + FormatDouble(camera.rotation(i, j));
      }
    }
    for (int i = 0; i < 3; ++i) {
      text += " " + FormatDouble(t[i]);
    }
    text += "\n";
  }
  internal::WriteTextFile(path, text);
}

}  // namespace dome::geometry
