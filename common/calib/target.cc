#include "calib/target.h"

#include <fmt/format.h>
#include <google/protobuf/util/json_util.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <set>

#include "calib.pb.h"
#include "core/error.h"
#include "io/file_util.h"

namespace dome::calib {

namespace fs = std::filesystem;
using core::Require;

int Target::Find(int id) const {
  for (size_t i = 0; i < points.size(); ++i) {
    if (points[i].id == id) return static_cast<int>(i);
  }
  return -1;
}

namespace {

template <typename Message>
Message ParseJson(const fs::path& path, const char* what) {
  const std::string json = io::ReadFileBytes(path);
  Message msg;
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  const auto status = google::protobuf::util::JsonStringToMessage(json, &msg, options);
  if (!status.ok()) {
    throw core::InputError(path.string(),
                           fmt::format("invalid {} JSON: {}", what, std::string(status.message())));
  }
  return msg;
}

}  // namespace

Target ReadTarget(const fs::path& path) {
  const auto msg = ParseJson<proto::TargetPoints>(path, "TargetPoints");
  const std::string where = path.string();
  Require(msg.format_version() == 1, where + ": format_version",
          fmt::format("expected 1, got {}", msg.format_version()));
  Target target;
  target.path = where;
  target.frame = msg.frame();
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

CalibViewFile ReadCalibView(const fs::path& path) {
  const auto msg = ParseJson<proto::CalibView>(path, "CalibView");
  const std::string where = path.string();
  Require(msg.format_version() == 1, where + ": format_version",
          fmt::format("expected 1, got {}", msg.format_version()));
  Require(!msg.camera().empty(), where + ": camera", "expected a camera id");
  Require(!msg.image().empty(), where + ": image", "expected the image file name");
  CalibViewFile view;
  view.path = where;
  view.camera = msg.camera();
  view.image = path.parent_path() / msg.image();
  view.target = path.parent_path() / (msg.target().empty() ? "target.json" : msg.target());
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

GridLayout InferGridLayout(const Target& target) {
  std::vector<TargetPoint> sorted = target.points;
  std::sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
  const int total = target.grid_points > 0 ? target.grid_points : static_cast<int>(sorted.size());
  std::vector<TargetPoint> plain(sorted.begin() + total, sorted.end());
  sorted.resize(total);
  for (int grids = 1; grids <= total; ++grids) {
    if (total % grids != 0) continue;
    const int per = total / grids;
    const int n = static_cast<int>(std::lround(std::sqrt(per)));
    if (n * n != per || n < 3) continue;
    GridLayout layout;
    bool ok = true;
    for (int g = 0; g < grids && ok; ++g) {
      Grid grid;
      grid.n = n;
      auto at = [&](int i, int j) -> const TargetPoint& { return sorted[g * per + n * j + i]; };
      const Eigen::Vector3d o = at(0, 0).position_mm;
      const Eigen::Vector3d ei = at(1, 0).position_mm - o;
      const Eigen::Vector3d ej = at(0, 1).position_mm - o;
      const double pitch = std::max(ei.norm(), ej.norm());
      if (!(pitch > 0)) {
        ok = false;
        break;
      }
      // every point where the grid's two axes put it, to 1% of the pitch
      for (int j = 0; j < n && ok; ++j) {
        for (int i = 0; i < n && ok; ++i) {
          if ((at(i, j).position_mm - (o + i * ei + j * ej)).norm() > 0.01 * pitch) ok = false;
          grid.ids.push_back(at(i, j).id);
        }
      }
      grid.normal = ei.cross(ej).normalized();
      layout.grids.push_back(grid);
    }
    if (!ok) continue;
    // Plain marks: in grid 0's plane, to 1% of its pitch.
    const Grid& g0 = layout.grids[0];
    const Eigen::Vector3d o = sorted[0].position_mm;
    const double pitch = (sorted[1].position_mm - o).norm();
    for (const TargetPoint& p : plain) {
      Require(std::abs(g0.normal.dot(p.position_mm - o)) <= 0.01 * pitch, target.path,
              fmt::format("plain mark id {} is not in the plane of the grid", p.id));
      layout.plain_ids.push_back(p.id);
    }
    return layout;
  }
  throw core::InputError(target.path,
                         "the points do not form square dot grids (G blocks of n x n "
                         "consecutive ids, id = base + n j + i, each a planar grid)");
}

}  // namespace dome::calib
