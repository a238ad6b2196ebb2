#include "schema/calib_json.h"

#include <fmt/format.h>

#include <cmath>
#include <set>

#include "calib.pb.h"
#include "core/error.h"
#include "io/file_util.h"
#include "schema/json.h"

namespace dome::schema {

namespace fs = std::filesystem;
using core::Require;

int Target::Find(int id) const {
  for (size_t i = 0; i < points.size(); ++i) {
    if (points[i].id == id) return static_cast<int>(i);
  }
  return -1;
}

namespace {

// The file's message, of format version 1.
template <class Message>
Message ReadVersion1(const fs::path& path) {
  Message msg;
  ParseJson(io::ReadFileBytes(path), path.string(),
            "invalid " + Message::descriptor()->name() + " JSON", &msg);
  Require(msg.format_version() == 1, path.string() + ": format_version",
          fmt::format("expected 1, got {}", msg.format_version()));
  return msg;
}

}  // namespace

Target ReadTarget(const fs::path& path) {
  const auto msg = ReadVersion1<proto::TargetPoints>(path);
  const std::string where = path.string();
  Target target;
  target.path = where;
  target.frame = msg.frame();
  target.description = msg.description();
  target.marker_radius_mm = msg.marker_radius_mm();
  target.key_marker_radius_mm = msg.key_marker_radius_mm();
  Require(std::isfinite(target.marker_radius_mm) && target.marker_radius_mm > 0,
          where + ": marker_radius_mm", "expected a positive number of mm");
  Require(std::isfinite(target.key_marker_radius_mm) && target.key_marker_radius_mm > 0,
          where + ": key_marker_radius_mm", "expected a positive number of mm");
  Require(msg.points_size() > 0, where + ": points", "the target has no points");
  Require(static_cast<int>(msg.grid_points()) <= msg.points_size(), where + ": grid_points",
          fmt::format("{} grid points, but the target has only {} points", msg.grid_points(),
                      msg.points_size()));
  target.grid_points = static_cast<int>(msg.grid_points());
  std::set<int> seen;
  for (int i = 0; i < msg.points_size(); ++i) {
    const auto& p = msg.points(i);
    const std::string field = fmt::format("{}: points[{}]", where, i);
    Require(std::isfinite(p.x_mm()) && std::isfinite(p.y_mm()) && std::isfinite(p.z_mm()), field,
            fmt::format("point id {} has a coordinate that is not a finite number", p.id()));
    Require(seen.insert(static_cast<int>(p.id())).second, field + ".id",
            fmt::format("duplicate id {}", p.id()));
    target.points.push_back(
        {static_cast<int>(p.id()), Eigen::Vector3d(p.x_mm(), p.y_mm(), p.z_mm())});
  }
  return target;
}

CalibView ReadCalibView(const fs::path& path) {
  const auto msg = ReadVersion1<proto::CalibView>(path);
  const std::string where = path.string();
  Require(!msg.camera().empty(), where + ": camera", "expected a camera id");
  Require(!msg.image().empty(), where + ": image", "expected the image file name");
  CalibView view;
  view.path = where;
  view.camera = msg.camera();
  view.image = path.parent_path() / msg.image();
  view.target = path.parent_path() / (msg.target().empty() ? "target.json" : msg.target());
  view.source = msg.source();
  if (msg.has_target_to_camera()) {
    const auto& pose = msg.target_to_camera();
    Require(pose.rotation_size() == 9 && pose.translation_mm_size() == 3,
            where + ": target_to_camera", "expected 9 rotation and 3 translation values");
    TargetPose p;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) p.rotation(r, c) = pose.rotation(3 * r + c);
      p.translation_mm(r) = pose.translation_mm(r);
    }
    view.target_to_camera = p;
  }
  std::set<int> seen;
  for (int i = 0; i < msg.points_size(); ++i) {
    const auto& p = msg.points(i);
    const std::string field = fmt::format("{}: points[{}]", where, i);
    Require(std::isfinite(p.x_px()) && std::isfinite(p.y_px()), field,
            "image coordinate is not a finite number");
    Require(seen.insert(static_cast<int>(p.id())).second, field + ".id",
            fmt::format("duplicate id {}", p.id()));
    view.points.push_back({static_cast<int>(p.id()), Eigen::Vector2d(p.x_px(), p.y_px())});
  }
  return view;
}

std::string TargetToJson(const Target& target) {
  proto::TargetPoints msg;
  msg.set_format_version(1);
  msg.set_grid_points(static_cast<uint32_t>(target.grid_points));
  msg.set_frame(target.frame);
  msg.set_description(target.description);
  msg.set_marker_radius_mm(target.marker_radius_mm);
  msg.set_key_marker_radius_mm(target.key_marker_radius_mm);
  for (const auto& p : target.points) {
    auto* q = msg.add_points();
    q->set_id(static_cast<uint32_t>(p.id));
    q->set_x_mm(p.position_mm.x());
    q->set_y_mm(p.position_mm.y());
    q->set_z_mm(p.position_mm.z());
  }
  return PrintJson(msg);
}

std::string CalibViewToJson(const CalibView& view) {
  proto::CalibView msg;
  msg.set_format_version(1);
  msg.set_camera(view.camera);
  msg.set_image(view.image.string());
  msg.set_target(view.target.string());
  msg.set_source(view.source);
  if (view.target_to_camera) {
    auto* pose = msg.mutable_target_to_camera();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) pose->add_rotation(view.target_to_camera->rotation(r, c));
    }
    for (int k = 0; k < 3; ++k) pose->add_translation_mm(view.target_to_camera->translation_mm[k]);
  }
  for (const auto& p : view.points) {
    auto* q = msg.add_points();
    q->set_id(static_cast<uint32_t>(p.id));
    q->set_x_px(p.pixel.x());
    q->set_y_px(p.pixel.y());
  }
  return PrintJson(msg);
}

}  // namespace dome::schema
