#include "take/crop.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/error.h"
#include "io/image_io.h"
#include "schema/rig_json.h"
#include "take/take.h"

namespace dome::take {

void CropBox::Check(const std::string& where) const {
  core::Require(min_mm.allFinite() && max_mm.allFinite(), where, "box corners must be finite");
  core::Require((max_mm.array() > min_mm.array()).all(), where,
                "box max corner must exceed the min corner on every axis");
  core::Require(margin_px >= 0, where, "margin must be >= 0 px, got " + std::to_string(margin_px));
}

cv::Rect BoxImageRect(const geometry::TsaiCamera& camera, const CropBox& box) {
  // Points along the twelve edges: with lens distortion an edge's image is curved, so
  // its corners alone do not bound it. (A box straddling the camera plane would need
  // more; the cameras of a take look at their volume from outside.)
  constexpr int kSteps = 32;
  double lo_u = std::numeric_limits<double>::infinity(), lo_v = lo_u;
  double hi_u = -lo_u, hi_v = -lo_u;
  const Eigen::Vector3d size = box.max_mm - box.min_mm;
  for (int axis = 0; axis < 3; ++axis) {
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    for (int corner = 0; corner < 4; ++corner) {
      Eigen::Vector3d p = box.min_mm;
      if (corner & 1) p[a1] = box.max_mm[a1];
      if (corner & 2) p[a2] = box.max_mm[a2];
      for (int s = 0; s <= kSteps; ++s) {
        p[axis] = box.min_mm[axis] + size[axis] * s / kSteps;
        Eigen::Vector2d px;
        if (!camera.Project(p, &px)) continue;
        lo_u = std::min(lo_u, px.x());
        hi_u = std::max(hi_u, px.x());
        lo_v = std::min(lo_v, px.y());
        hi_v = std::max(hi_v, px.y());
      }
    }
  }
  if (!(lo_u <= hi_u && lo_v <= hi_v)) return {};
  return GrownPixelRect(camera, lo_u, lo_v, hi_u, hi_v, box.margin_px);
}

cv::Rect GrownPixelRect(const geometry::TsaiCamera& camera, double lo_u, double lo_v, double hi_u,
                        double hi_v, double margin_px) {
  const double m = margin_px;
  const int x0 = int(std::max(0.0, std::floor(lo_u - m)));
  const int y0 = int(std::max(0.0, std::floor(lo_v - m)));
  const int x1 = int(std::min(double(camera.width_px), std::ceil(hi_u + m) + 1));
  const int y1 = int(std::min(double(camera.height_px), std::ceil(hi_v + m) + 1));
  if (x1 <= x0 || y1 <= y0) return {};
  return {x0, y0, x1 - x0, y1 - y0};
}

geometry::TsaiCamera CropCamera(const geometry::TsaiCamera& camera, const cv::Rect& rect) {
  DOME_CHECK(!rect.empty() && rect.x >= 0 && rect.y >= 0 && rect.br().x <= camera.width_px &&
                 rect.br().y <= camera.height_px,
             "crop rectangle inside the image");
  geometry::TsaiCamera c = camera;
  // Pixel = sx * Xd / dpx + cx: a shift of the pixel origin is a shift of the centre.
  c.cx_px -= rect.x;
  c.cy_px -= rect.y;
  c.width_px = rect.width;
  c.height_px = rect.height;
  return c;
}

CropSummary CropTakeToBox(const std::filesystem::path& dir, const CropBox& box) {
  box.Check("crop box");
  take::Take take = take::OpenTake(dir);
  core::Require(!std::filesystem::exists(dir / "truth"), (dir / "truth").string(),
                "a take with ground truth cannot be cropped (its depth maps keep the full size)");
  CropSummary summary;
  double before = 0, after = 0;
  for (auto& rc : take.rig.cameras) {
    const geometry::TsaiCamera& cam = rc.model;
    before += double(cam.width_px) * cam.height_px;
    const cv::Rect rect = BoxImageRect(cam, box);
    if (rect.empty() || rect == cv::Rect(0, 0, cam.width_px, cam.height_px)) {
      after += double(cam.width_px) * cam.height_px;
      continue;
    }
    for (const std::string& instant : take.instants) {
      const auto path = take.FramePath(instant, cam.id);
      const cv::Mat image = io::ReadImage(path, io::ImageMode::kUnchanged);
      core::Require(image.cols == cam.width_px && image.rows == cam.height_px, path.string(),
                    "expected " + std::to_string(cam.width_px) + "x" +
                        std::to_string(cam.height_px) + " pixels (rig.json), got " +
                        std::to_string(image.cols) + "x" + std::to_string(image.rows));
      io::WriteImage(path, image(rect).clone());
    }
    rc.model = CropCamera(cam, rect);
    after += double(rect.area());
    ++summary.cameras_cropped;
  }
  schema::WriteRig(take.rig, take.RigPath());
  summary.pixel_fraction = before > 0 ? after / before : 1.0;
  return summary;
}

}  // namespace dome::take
