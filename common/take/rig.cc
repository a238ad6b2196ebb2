#include "take/rig.h"

#include <google/protobuf/util/json_util.h>

#include <cmath>
#include <set>

#include "core/error.h"
#include "io/file_util.h"
#include "rig.pb.h"

namespace dome::take {
namespace {

using core::InputError;
using core::Require;

std::string CameraWhere(const std::string& where, size_t i, const std::string& id) {
  return where + ": cameras[" + std::to_string(i) + "] (id '" + id + "')";
}

RigCamera FromProto(const proto::Camera& c, const std::string& where) {
  RigCamera out;
  geometry::TsaiCamera& m = out.model;
  m.id = c.id();
  m.width_px = c.width_px();
  m.height_px = c.height_px();
  Require(c.has_sensor(), where + ".sensor", "missing (expected ncx, nfx, dx_mm, dy_mm)");
  m.sensor.ncx = c.sensor().ncx();
  m.sensor.nfx = c.sensor().nfx();
  m.sensor.dx_mm = c.sensor().dx_mm();
  m.sensor.dy_mm = c.sensor().dy_mm();
  m.focal_mm = c.focal_mm();
  m.kappa1_per_mm2 = c.kappa1_per_mm2();
  m.cx_px = c.cx_px();
  m.cy_px = c.cy_px();
  m.sx = c.sx();
  Require(c.rotation_size() == 9, where + ".rotation",
          "expected 9 values (row-major 3x3), got " + std::to_string(c.rotation_size()));
  Require(c.translation_mm_size() == 3, where + ".translation_mm",
          "expected 3 values, got " + std::to_string(c.translation_mm_size()));
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) m.rotation(r, k) = c.rotation(3 * r + k);
    m.translation_mm(r) = c.translation_mm(r);
  }
  out.neighbours.assign(c.neighbours().begin(), c.neighbours().end());
  return out;
}

void ToProto(const RigCamera& in, proto::Camera* c) {
  const geometry::TsaiCamera& m = in.model;
  c->set_id(m.id);
  c->set_width_px(m.width_px);
  c->set_height_px(m.height_px);
  c->mutable_sensor()->set_ncx(m.sensor.ncx);
  c->mutable_sensor()->set_nfx(m.sensor.nfx);
  c->mutable_sensor()->set_dx_mm(m.sensor.dx_mm);
  c->mutable_sensor()->set_dy_mm(m.sensor.dy_mm);
  c->set_focal_mm(m.focal_mm);
  c->set_kappa1_per_mm2(m.kappa1_per_mm2);
  c->set_cx_px(m.cx_px);
  c->set_cy_px(m.cy_px);
  c->set_sx(m.sx);
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) c->add_rotation(m.rotation(r, k));
  }
  for (int r = 0; r < 3; ++r) c->add_translation_mm(m.translation_mm(r));
  for (const auto& n : in.neighbours) c->add_neighbours(n);
}

}  // namespace

int Rig::Find(const std::string& id) const {
  for (size_t i = 0; i < cameras.size(); ++i) {
    if (cameras[i].model.id == id) return static_cast<int>(i);
  }
  return -1;
}

void CheckRig(const Rig& rig, const std::string& where) {
  Require(!rig.cameras.empty(), where + ": cameras", "expected at least one camera");
  Require(std::isfinite(rig.source_unit_mm) && rig.source_unit_mm > 0, where + ": source_unit_mm",
          "expected a positive number of millimetres per source unit");
  std::set<std::string> ids;
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const auto& cam = rig.cameras[i];
    const std::string cw = CameraWhere(where, i, cam.model.id);
    Require(!cam.model.id.empty(), cw + ".id", "expected a non-empty camera id");
    Require(cam.model.id.find_first_of("/\\ \t\n") == std::string::npos && cam.model.id != "." &&
                cam.model.id != "..",
            cw + ".id", "a camera id names files: no slashes, spaces or dot-only names");
    Require(ids.insert(cam.model.id).second, cw + ".id",
            "duplicate camera id '" + cam.model.id + "'");
    cam.model.Check(cw);
  }
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const auto& cam = rig.cameras[i];
    for (const auto& n : cam.neighbours) {
      const std::string nw = CameraWhere(where, i, cam.model.id) + ".neighbours";
      Require(n != cam.model.id, nw, "a camera cannot be its own neighbour");
      Require(ids.count(n) == 1, nw, "unknown camera id '" + n + "'");
    }
  }
}

Rig ParseRigJson(const std::string& json, const std::string& where) {
  proto::Rig msg;
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  const auto status = google::protobuf::util::JsonStringToMessage(json, &msg, options);
  if (!status.ok()) {
    throw InputError(where, "invalid rig JSON: " + std::string(status.message()));
  }
  Require(msg.format_version() == kRigFormatVersion, where + ": format_version",
          "expected " + std::to_string(kRigFormatVersion) + ", got " +
              std::to_string(msg.format_version()));
  Rig rig;
  rig.source = msg.source();
  rig.source_unit = msg.source_unit();
  rig.source_unit_mm = msg.source_unit_mm();
  for (int i = 0; i < msg.cameras_size(); ++i) {
    rig.cameras.push_back(FromProto(msg.cameras(i), CameraWhere(where, i, msg.cameras(i).id())));
  }
  CheckRig(rig, where);
  return rig;
}

std::string RigToJson(const Rig& rig) {
  proto::Rig msg;
  msg.set_format_version(kRigFormatVersion);
  msg.set_source(rig.source);
  msg.set_source_unit(rig.source_unit);
  msg.set_source_unit_mm(rig.source_unit_mm);
  for (const auto& cam : rig.cameras) ToProto(cam, msg.add_cameras());
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  std::string out;
  const auto status = google::protobuf::util::MessageToJsonString(msg, &out, options);
  DOME_CHECK(status.ok(), std::string(status.message()));
  return out;
}

Rig ReadRig(const std::filesystem::path& path) {
  return ParseRigJson(io::ReadFileBytes(path), path.string());
}

void WriteRig(const Rig& rig, const std::filesystem::path& path) {
  CheckRig(rig, path.string());
  io::WriteFileAtomically(path, RigToJson(rig));
}

}  // namespace dome::take
