#include "geometry/tsai_xml.h"

#include <cctype>
#include <cmath>
#include <string_view>
#include <utility>
#include <vector>

#include "core/error.h"
#include "geometry/parse_util.h"

namespace dome::geometry {
namespace {

using internal::FormatDouble;
using internal::ParseDouble;
using internal::ParseInt;
using internal::Where;

// A start (or empty-element) tag and its attributes; enough XML for this schema. No
// XML library is a dependency of dome, and this schema uses nothing but attributes.
struct Element {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attributes;
  int line = 0;
};

std::string DecodeEntities(std::string_view text) {
  static const std::pair<std::string_view, char> kEntities[] = {
      {"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}};
  std::string out;
  for (size_t i = 0; i < text.size();) {
    bool replaced = false;
    if (text[i] == '&') {
      for (const auto& [entity, c] : kEntities) {
        if (text.substr(i, entity.size()) == entity) {
          out.push_back(c);
          i += entity.size();
          replaced = true;
          break;
        }
      }
    }
    if (!replaced) {
      out.push_back(text[i++]);
    }
  }
  return out;
}

std::string EncodeEntities(std::string_view text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out.push_back(c);
    }
  }
  return out;
}

bool IsNameChar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ':' || c == '-' ||
         c == '.';
}

// All start tags of the document, in order. Skips the declaration, comments, DOCTYPE,
// closing tags and text.
std::vector<Element> ScanElements(const std::string& text, const std::string& path) {
  std::vector<Element> elements;
  int line = 1;
  size_t i = 0;
  auto line_where = [&](int at) { return Where(path, "line " + std::to_string(at)); };
  auto skip_past = [&](std::string_view terminator) {
    const size_t end = text.find(terminator, i);
    core::Require(end != std::string::npos, line_where(line),
                  "malformed XML: no closing '" + std::string(terminator) + "'");
    for (size_t k = i; k < end; ++k) {
      line += text[k] == '\n';
    }
    i = end + terminator.size();
  };
  while (i < text.size()) {
    if (text[i] != '<') {
      line += text[i] == '\n';
      ++i;
      continue;
    }
    if (text.compare(i, 4, "<!--") == 0) {
      skip_past("-->");
    } else if (text.compare(i, 2, "<?") == 0) {
      skip_past("?>");
    } else if (text.compare(i, 2, "<!") == 0 || text.compare(i, 2, "</") == 0) {
      skip_past(">");
    } else {
      Element element;
      element.line = line;
      ++i;
      while (i < text.size() && IsNameChar(text[i])) {
        element.name.push_back(text[i++]);
      }
      core::Require(!element.name.empty(), line_where(line),
                    "malformed XML: '<' without a tag name");
      while (true) {
        while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) {
          line += text[i++] == '\n';
        }
        core::Require(i < text.size(), line_where(line),
                      "malformed XML: element <" + element.name + "> is not closed");
        if (text[i] == '>') {
          ++i;
          break;
        }
        if (text.compare(i, 2, "/>") == 0) {
          i += 2;
          break;
        }
        std::string name;
        while (i < text.size() && IsNameChar(text[i])) {
          name.push_back(text[i++]);
        }
        core::Require(!name.empty(), line_where(line),
                      "malformed XML in <" + element.name + ">: unexpected '" +
                          std::string(1, text[i]) + "'");
        while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) {
          line += text[i++] == '\n';
        }
        core::Require(i < text.size() && text[i] == '=', line_where(line),
                      "malformed XML: attribute " + element.name + "." + name + " has no '='");
        ++i;
        while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) {
          line += text[i++] == '\n';
        }
        core::Require(
            i < text.size() && (text[i] == '"' || text[i] == '\''), line_where(line),
            "malformed XML: attribute " + element.name + "." + name + " has no quoted value");
        const char quote = text[i++];
        const size_t end = text.find(quote, i);
        core::Require(end != std::string::npos, line_where(line),
                      "malformed XML: value of " + element.name + "." + name + " is not closed");
        const std::string_view raw(text.data() + i, end - i);
        for (const char c : raw) {
          line += c == '\n';
        }
        element.attributes.emplace_back(name, DecodeEntities(raw));
        i = end + 1;
      }
      elements.push_back(std::move(element));
    }
  }
  return elements;
}

class CameraFile {
 public:
  CameraFile(std::string path, std::vector<Element> elements)
      : path_(std::move(path)), elements_(std::move(elements)) {}

  const Element& Get(const std::string& name) const {
    const Element* found = nullptr;
    for (const Element& e : elements_) {
      if (e.name != name) {
        continue;
      }
      core::Require(found == nullptr, Where(path_, name),
                    "element <" + name + "> appears twice (lines " +
                        std::to_string(found ? found->line : 0) + " and " + std::to_string(e.line) +
                        "); expected one camera per file");
      found = &e;
    }
    core::Require(found != nullptr, Where(path_, name), "missing element <" + name + ">");
    return *found;
  }

  std::string Text(const Element& e, const std::string& attribute) const {
    for (const auto& [key, value] : e.attributes) {
      if (key == attribute) {
        return value;
      }
    }
    throw core::InputError(Where(path_, e.name + "." + attribute),
                           "missing attribute " + attribute + " of <" + e.name + ">");
  }

  double Number(const Element& e, const std::string& attribute) const {
    return ParseDouble(Text(e, attribute), Where(path_, e.name + "." + attribute));
  }

  double Positive(const Element& e, const std::string& attribute) const {
    const double value = Number(e, attribute);
    core::Require(value > 0.0, Where(path_, e.name + "." + attribute),
                  "must be positive, got " + FormatDouble(value));
    return value;
  }

  int PositiveInt(const Element& e, const std::string& attribute) const {
    const int value = ParseInt(Text(e, attribute), Where(path_, e.name + "." + attribute));
    core::Require(value > 0, Where(path_, e.name + "." + attribute),
                  "must be positive, got " + std::to_string(value));
    return value;
  }

  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::vector<Element> elements_;
};

void RequireSamePitch(double stored, double derived, const std::string& where,
                      const std::string& formula) {
  core::Require(std::abs(stored - derived) <= 1e-6 * derived, where,
                "= " + FormatDouble(stored) + " disagrees with " + formula + " = " +
                    FormatDouble(derived) + " (relative tolerance 1e-6)");
}

}  // namespace

TsaiCamera ReadTsaiXml(const std::string& path) {
  const CameraFile file(path, ScanElements(internal::ReadTextFile(path), path));
  const Element& camera_element = file.Get("Camera");
  const Element& geometry = file.Get("Geometry");
  const Element& intrinsic = file.Get("Intrinsic");
  const Element& extrinsic = file.Get("Extrinsic");

  TsaiCamera camera;
  camera.id = file.Text(camera_element, "name");
  camera.width_px = file.PositiveInt(geometry, "width");
  camera.height_px = file.PositiveInt(geometry, "height");
  camera.sensor.ncx = file.Positive(geometry, "ncx");
  camera.sensor.nfx = file.Positive(geometry, "nfx");
  camera.sensor.dx_mm = file.Positive(geometry, "dx");
  camera.sensor.dy_mm = file.Positive(geometry, "dy");
  RequireSamePitch(file.Positive(geometry, "dpx"), camera.sensor.dpx_mm(),
                   Where(path, "Geometry.dpx"), "dx * ncx / nfx");
  RequireSamePitch(file.Positive(geometry, "dpy"), camera.sensor.dpy_mm(),
                   Where(path, "Geometry.dpy"), "dy");

  camera.focal_mm = file.Positive(intrinsic, "focal");
  camera.kappa1_per_mm2 = file.Number(intrinsic, "kappa1");
  camera.cx_px = file.Number(intrinsic, "cx");
  camera.cy_px = file.Number(intrinsic, "cy");
  camera.sx = file.Positive(intrinsic, "sx");

  camera.translation_mm = {file.Number(extrinsic, "tx"), file.Number(extrinsic, "ty"),
                           file.Number(extrinsic, "tz")};
  camera.rotation = RotationFromTsaiAngles(
      file.Number(extrinsic, "rx"), file.Number(extrinsic, "ry"), file.Number(extrinsic, "rz"));
  camera.Check(path);  // everything above is checked field by field; this is a backstop
  return camera;
}

void WriteTsaiXml(const std::string& path, const TsaiCamera& camera) {
  camera.Check(Where(path, "camera '" + camera.id + "'"));
  core::Require(!camera.lens.Any(), Where(path, "camera '" + camera.id + "'"),
                "has an OpenCV lens, which Tsai's XML (kappa1 only) cannot hold");
  const auto attr = [](const char* name, double value) {
    return std::string(" ") + name + "=\"" + FormatDouble(value) + "\"";
  };
  const Eigen::Vector3d angles = TsaiAnglesFromRotation(camera.rotation);
  std::string xml = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n\n";
  xml += "<Camera name=\"" + EncodeEntities(camera.id) + "\">\n";
  xml += "  <Geometry width=\"" + std::to_string(camera.width_px) + "\" height=\"" +
         std::to_string(camera.height_px) + "\"" + attr("ncx", camera.sensor.ncx) +
         attr("nfx", camera.sensor.nfx) + "\n           " + attr("dx", camera.sensor.dx_mm) +
         attr("dy", camera.sensor.dy_mm) + attr("dpx", camera.sensor.dpx_mm()) +
         attr("dpy", camera.sensor.dpy_mm()) + "/>\n";
  xml += "  <Intrinsic" + attr("focal", camera.focal_mm) + attr("kappa1", camera.kappa1_per_mm2) +
         attr("cx", camera.cx_px) + attr("cy", camera.cy_px) + attr("sx", camera.sx) + "/>\n";
  xml += "  <Extrinsic" + attr("tx", camera.translation_mm.x()) +
         attr("ty", camera.translation_mm.y()) + attr("tz", camera.translation_mm.z()) +
         "\n            " + attr("rx", angles.x()) + attr("ry", angles.y()) +
         attr("rz", angles.z()) + "/>\n";
  xml += "</Camera>\n";
  internal::WriteTextFile(path, xml);
}

}  // namespace dome::geometry
