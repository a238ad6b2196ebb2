#include "calib/target.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <set>

#include "core/error.h"

namespace dome::calib {

namespace fs = std::filesystem;
using core::Require;

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
