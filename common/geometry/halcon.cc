#include "geometry/halcon.h"

#include <cctype>
#include <map>
#include <string_view>
#include <vector>

#include "core/error.h"
#include "geometry/parse_util.h"

namespace dome::geometry {
namespace {

using internal::FormatDouble;
using internal::ParseDouble;
using internal::ParseInt;
using internal::Where;

// The data prints R with 6 decimals; see the header.
constexpr double kFileRotationTolerance = 1e-5;

struct Entry {
  std::string value;
  int line = 0;
};

bool IsIdentifier(std::string_view text) {
  if (text.empty() || !std::isalpha(static_cast<unsigned char>(text[0]))) {
    return false;
  }
  for (const char c : text) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') {
      return false;
    }
  }
  return true;
}

// "Name:shortname:value;" entries, keyed by Name. Type lines ("DOUBLE:0.0:;"), the
// ParGroup header, descriptions and comments are skipped.
std::map<std::string, Entry> ParseEntries(const std::string& text, const std::string& path) {
  static const char* const kNotParameters[] = {"ParGroup", "BOOL",   "XBOOL", "INT",
                                               "FLOAT",    "DOUBLE", "STRING"};
  std::map<std::string, Entry> entries;
  const std::vector<std::string> lines = internal::SplitLines(text);
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string_view line = internal::Trim(lines[i]);
    if (line.empty() || line[0] == '#' || line[0] == '"') {
      continue;
    }
    const size_t first = line.find(':');
    if (first == std::string_view::npos) {
      continue;
    }
    const std::string_view name = line.substr(0, first);
    if (!IsIdentifier(name)) {
      continue;
    }
    bool skip = false;
    for (const char* other : kNotParameters) {
      skip = skip || name == other;
    }
    if (skip) {
      continue;
    }
    const size_t second = line.find(':', first + 1);
    const size_t end = line.rfind(';');
    const std::string where = Where(path, std::string(name));
    core::Require(second != std::string_view::npos && end != std::string_view::npos && end > second,
                  where + " (line " + std::to_string(i + 1) + ")",
                  "expected 'Name:shortname:value;', got '" + std::string(line) + "'");
    if (const auto it = entries.find(std::string(name)); it != entries.end()) {
      throw core::InputError(where, "appears twice (lines " + std::to_string(it->second.line) +
                                        " and " + std::to_string(i + 1) + ")");
    }
    entries[std::string(name)] = {std::string(line.substr(second + 1, end - second - 1)),
                                  static_cast<int>(i + 1)};
  }
  return entries;
}

class IntrinsicsFile {
 public:
  IntrinsicsFile(std::string path, std::map<std::string, Entry> entries)
      : path_(std::move(path)), entries_(std::move(entries)) {}

  bool Has(const std::string& name) const { return entries_.count(name) > 0; }

  const std::string& Text(const std::string& name) const {
    const auto it = entries_.find(name);
    core::Require(it != entries_.end(), Where(path_, name), "missing parameter " + name);
    return it->second.value;
  }
  double Number(const std::string& name) const {
    return ParseDouble(Text(name), Where(path_, name));
  }
  double Positive(const std::string& name) const {
    const double value = Number(name);
    core::Require(value > 0.0, Where(path_, name), "must be positive, got " + FormatDouble(value));
    return value;
  }
  int PositiveInt(const std::string& name) const {
    const int value = ParseInt(Text(name), Where(path_, name));
    core::Require(value > 0, Where(path_, name), "must be positive, got " + std::to_string(value));
    return value;
  }
  void RequireZero(const std::string& name, const std::string& why) const {
    const double value = Number(name);
    core::Require(value == 0.0, Where(path_, name), "is " + FormatDouble(value) + "; " + why);
  }

 private:
  std::string path_;
  std::map<std::string, Entry> entries_;
};

void RequireNoDistortion(const TsaiCamera& camera, const std::string& path) {
  core::Require(!camera.lens.Any(), Where(path, "camera '" + camera.id + "'"),
                "has an OpenCV lens, which these HALCON files cannot hold; undistort the "
                "images (geometry/undistort.h) and write the ideal camera instead");
  core::Require(camera.kappa1_per_mm2 == 0.0, Where(path, "camera '" + camera.id + "'"),
                "kappa1 = " + FormatDouble(camera.kappa1_per_mm2) +
                    ": HALCON's distortion models differ from Tsai's; undistort the images "
                    "(geometry/undistort.h) and write the ideal camera instead");
}

}  // namespace

TsaiCamera ReadHalconIntrinsics(const std::string& path, const std::string& id) {
  const IntrinsicsFile file(path, ParseEntries(internal::ReadTextFile(path), path));
  const std::string not_tsai =
      "HALCON's distortion model is not Tsai's kappa1 and is not converted; only "
      "distortion-free (already undistorted) cameras are supported";
  if (file.Has("Kappa")) {
    file.RequireZero("Kappa", not_tsai);
  } else {
    core::Require(file.Has("Poly1"), Where(path, "Poly1"),
                  "missing parameter: expected Poly1..Poly5 (area_scan_polynomial) or Kappa "
                  "(area_scan_division)");
    for (const char* poly : {"Poly1", "Poly2", "Poly3", "Poly4", "Poly5"}) {
      file.RequireZero(poly, not_tsai);
    }
  }
  const double focus_m = file.Number("Focus");
  core::Require(focus_m > 0.0, Where(path, "Focus"),
                "must be positive (0 means a telecentric lens, which is not a Tsai camera), got " +
                    FormatDouble(focus_m));

  TsaiCamera camera;
  camera.id = id;
  camera.width_px = file.PositiveInt("ImageWidth");
  camera.height_px = file.PositiveInt("ImageHeight");
  camera.sensor.ncx = camera.width_px;
  camera.sensor.nfx = camera.width_px;
  camera.sensor.dx_mm = 1000.0 * file.Positive("Sx");
  camera.sensor.dy_mm = 1000.0 * file.Positive("Sy");
  camera.focal_mm = 1000.0 * focus_m;
  camera.sx = 1.0;
  camera.cx_px = file.Number("Cx");
  camera.cy_px = file.Number("Cy");
  camera.kappa1_per_mm2 = 0.0;
  camera.Check(path);
  return camera;
}

void ReadHalconExtrinsics(const std::string& path, Eigen::Matrix3d* rotation_world_to_camera,
                          Eigen::Vector3d* translation_world_to_camera_mm) {
  std::string text = internal::ReadTextFile(path);
  if (const size_t hash = text.find('#'); hash != std::string::npos) {
    text.resize(hash);
  }
  const std::vector<std::string> tokens = internal::SplitWhitespace(text);
  core::Require(tokens.size() == 12, path,
                "expected 12 numbers (row-major 3x4 camera->world [R | t], metres), got " +
                    std::to_string(tokens.size()) + " fields");
  Eigen::Matrix3d r_cw;
  Eigen::Vector3d t_cw_m;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 4; ++col) {
      const int index = 4 * row + col;
      const std::string where =
          Where(path, "number " + std::to_string(index + 1) + " (row " + std::to_string(row + 1) +
                          ", column " + std::to_string(col + 1) + ")");
      const double value = ParseDouble(tokens[index], where);
      if (col < 3) {
        r_cw(row, col) = value;
      } else {
        t_cw_m[row] = value;
      }
    }
  }
  r_cw = internal::RequireNearRotation(r_cw, kFileRotationTolerance, Where(path, "R"));
  // camera -> world (R, t)  ==>  world -> camera (R^T, -R^T t), metres -> mm.
  *rotation_world_to_camera = r_cw.transpose();
  *translation_world_to_camera_mm = -(r_cw.transpose() * t_cw_m) * 1000.0;
}

TsaiCamera ReadHalconCamera(const std::string& intrinsics_path, const std::string& extrinsics_path,
                            const std::string& id) {
  TsaiCamera camera = ReadHalconIntrinsics(intrinsics_path, id);
  ReadHalconExtrinsics(extrinsics_path, &camera.rotation, &camera.translation_mm);
  camera.Check(extrinsics_path);
  return camera;
}

void WriteHalconIntrinsics(const std::string& path, const TsaiCamera& camera) {
  camera.Check(Where(path, "camera '" + camera.id + "'"));
  RequireNoDistortion(camera, path);
  struct Parameter {
    const char* name;
    const char* short_name;
    std::string value;
    const char* type;
    const char* description;
  };
  const Parameter parameters[] = {
      {"Focus", "foc", FormatDouble(camera.focal_mm / 1000.0),
       "DOUBLE:0.0:", "Focal length of the lens"},
      {"Poly1", "poly1", "0", "DOUBLE::", "1st polynomial distortion coefficient"},
      {"Poly2", "poly2", "0", "DOUBLE::", "2nd polynomial distortion coefficient"},
      {"Poly3", "poly3", "0", "DOUBLE::", "3rd polynomial distortion coefficient"},
      {"Poly4", "poly4", "0", "DOUBLE::", "4th polynomial distortion coefficient * 1000"},
      {"Poly5", "poly5", "0", "DOUBLE::", "5th polynomial distortion coefficient * 1000"},
      // sx folded into the cell width: column = sx Xd / dpx + Cx = Xd / (dpx / sx) + Cx.
      {"Sx", "sx", FormatDouble(camera.sensor.dpx_mm() / camera.sx / 1000.0),
       "DOUBLE:0.0:", "Width of a cell on the sensor"},
      {"Sy", "sy", FormatDouble(camera.sensor.dpy_mm() / 1000.0),
       "DOUBLE:0.0:", "Height of a cell on the sensor"},
      {"Cx", "cx", FormatDouble(camera.cx_px), "DOUBLE::", "X-coordinate of the image center"},
      {"Cy", "cy", FormatDouble(camera.cy_px), "DOUBLE::", "Y-coordinate of the image center"},
      {"ImageWidth", "imgw", std::to_string(camera.width_px), "INT:1:32768", "Width of the images"},
      {"ImageHeight", "imgh", std::to_string(camera.height_px), "INT:1:32768",
       "Height of the images"},
  };
  std::string text =
      "#\n# INTERNAL CAMERA PARAMETERS\n#\n\n"
      "##############################################################################\n"
      "#\n#  Camera : Parameter\n";
  for (const Parameter& p : parameters) {
    text += std::string("#    >  ") + p.name + "\n";
  }
  text +=
      "#\n"
      "##############################################################################\n\n"
      "ParGroup: Camera: Parameter;\n\t\"Internal camera parameters\";\n\n";
  for (const Parameter& p : parameters) {
    text += std::string(p.name) + ":" + p.short_name + ":\t" + p.value + ";\n\t" + p.type +
            ";\n\t\"" + p.description + "\";\n\n";
  }
  text += "\n#\n# Written by dome (HALCON 12 format)\n#\n";
  internal::WriteTextFile(path, text);
}

void WriteHalconExtrinsics(const std::string& path, const TsaiCamera& camera) {
  camera.Check(Where(path, "camera '" + camera.id + "'"));
  // world -> camera (R, t mm)  ==>  camera -> world (R^T, centre), metres.
  const Eigen::Matrix3d r_cw = camera.rotation.transpose();
  const Eigen::Vector3d t_cw_m = camera.CentreWorld() / 1000.0;
  std::string text;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 4; ++col) {
      text += FormatDouble(col < 3 ? r_cw(row, col) : t_cw_m[row]) + " ";
    }
  }
  text += "\n";
  internal::WriteTextFile(path, text);
}

}  // namespace dome::geometry
