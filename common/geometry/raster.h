// Scan conversion of one triangle in pixel coordinates (x right, y down, (0, 0) the
// centre of the top-left pixel), shared by the texture stage's z-buffers and the
// silhouette renderer so that both cover exactly the same pixels.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

namespace dome::geometry {

// Calls visit(x, y, la, lb, lc) for every pixel centre (x, y) of a width x height image
// that lies inside or on the triangle a b c, with its image-space barycentric weights
// (la + lb + lc = 1; a centre on an edge, |weight| at rounding level, counts). Nothing
// for a triangle of no area or wholly outside the image. `divide` computes the weights
// by dividing by the doubled area, as exact paths do; false multiplies by its inverse
// (the same weights to within rounding, faster).
template <class Visit>
void RasterizeTriangle(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                       int width, int height, bool divide, Visit&& visit) {
  const int x0 = std::max(0, int(std::ceil(std::min({a.x(), b.x(), c.x()}))));
  const int x1 = std::min(width - 1, int(std::floor(std::max({a.x(), b.x(), c.x()}))));
  const int y0 = std::max(0, int(std::ceil(std::min({a.y(), b.y(), c.y()}))));
  const int y1 = std::min(height - 1, int(std::floor(std::max({a.y(), b.y(), c.y()}))));
  const double area = (b.x() - a.x()) * (c.y() - a.y()) - (c.x() - a.x()) * (b.y() - a.y());
  if (x0 > x1 || y0 > y1 || std::abs(area) < 1e-12) return;
  const double inv_area = 1.0 / area;
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      double la = (b.x() - x) * (c.y() - y) - (c.x() - x) * (b.y() - y);
      double lb = (c.x() - x) * (a.y() - y) - (a.x() - x) * (c.y() - y);
      if (divide) {
        la /= area, lb /= area;
      } else {
        la *= inv_area, lb *= inv_area;
      }
      const double lc = 1.0 - la - lb;
      if (la < -1e-9 || lb < -1e-9 || lc < -1e-9) continue;
      visit(x, y, la, lb, lc);
    }
  }
}

}  // namespace dome::geometry
