#include "schema/rig_json.h"

#include "core/error.h"
#include "io/file_util.h"
#include "rig.pb.h"
#include "schema/json.h"

namespace dome::schema {
namespace {

using core::Require;
using geometry::Rig;
using geometry::RigCamera;

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
  if (c.opencv_distortion_size() > 0) {
    Require(
        c.opencv_distortion_size() == 5, where + ".opencv_distortion",
        "expected 5 values (k1 k2 p1 p2 k3), got " + std::to_string(c.opencv_distortion_size()));
    m.lens = {c.opencv_distortion(0), c.opencv_distortion(1), c.opencv_distortion(2),
              c.opencv_distortion(3), c.opencv_distortion(4)};
  }
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
  if (m.lens.Any()) {
    for (double v : {m.lens.k1, m.lens.k2, m.lens.p1, m.lens.p2, m.lens.k3})
      c->add_opencv_distortion(v);
  }
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

Rig ParseRigJson(const std::string& json, const std::string& where) {
  proto::Rig msg;
  ParseJson(json, where, "invalid rig JSON", &msg);
  Require(msg.format_version() == kRigFormatVersion, where + ": format_version",
          "expected " + std::to_string(kRigFormatVersion) + ", got " +
              std::to_string(msg.format_version()));
  Rig rig;
  rig.source = msg.source();
  rig.source_unit = msg.source_unit();
  rig.source_unit_mm = msg.source_unit_mm();
  for (int i = 0; i < msg.cameras_size(); ++i) {
    rig.cameras.push_back(
        FromProto(msg.cameras(i), geometry::RigCameraWhere(where, i, msg.cameras(i).id())));
  }
  geometry::CheckRig(rig, where);
  return rig;
}

std::string RigToJson(const Rig& rig) {
  proto::Rig msg;
  msg.set_format_version(kRigFormatVersion);
  msg.set_source(rig.source);
  msg.set_source_unit(rig.source_unit);
  msg.set_source_unit_mm(rig.source_unit_mm);
  for (const auto& cam : rig.cameras) ToProto(cam, msg.add_cameras());
  return PrintJson(msg);
}

Rig ReadRig(const std::filesystem::path& path) {
  return ParseRigJson(io::ReadFileBytes(path), path.string());
}

void WriteRig(const Rig& rig, const std::filesystem::path& path) {
  geometry::CheckRig(rig, path.string());
  io::WriteFileAtomically(path, RigToJson(rig));
}

}  // namespace dome::schema
