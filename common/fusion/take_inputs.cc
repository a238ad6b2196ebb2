#include "fusion/take_inputs.h"

#include <cmath>
#include <random>

#include "core/error.h"
#include "io/depth_tiff.h"

namespace dome::fusion {

void TruthDepthOptions::Check() const {
  core::Require(std::isfinite(noise_sigma_mm) && noise_sigma_mm >= 0.0, "noise_sigma_mm",
                "must be >= 0 mm, got " + std::to_string(noise_sigma_mm));
}

std::vector<RangeImage> LoadTruthRangeImages(const take::Take& take, const std::string& instant,
                                             const TruthDepthOptions& options) {
  options.Check();
  std::vector<RangeImage> images;
  for (size_t c = 0; c < take.rig.cameras.size(); ++c) {
    const auto& cam = take.rig.cameras[c].model;
    RangeImage image;
    image.camera = cam;
    image.distorted_pixels = true;  // rendered through the camera's lens
    const auto path = take.TruthDepthPath(instant, cam.id);
    image.where = path.string();
    image.depth_mm = io::ReadDepthTiff(path);
    if (options.noise_sigma_mm > 0.0) {
      std::mt19937_64 rng(options.seed * 1000003ULL + c);
      std::normal_distribution<double> noise(0.0, options.noise_sigma_mm);
      for (int y = 0; y < image.depth_mm.rows; ++y) {
        float* row = image.depth_mm.ptr<float>(y);
        for (int x = 0; x < image.depth_mm.cols; ++x) {
          if (row[x] > 0) row[x] = float(std::max(1.0, row[x] + noise(rng)));
        }
      }
    }
    images.push_back(std::move(image));
  }
  return images;
}

std::vector<RangeImage> LoadRangeImagesFromDir(const take::Take& take,
                                               const std::filesystem::path& dir) {
  std::vector<RangeImage> images;
  for (const auto& rc : take.rig.cameras) {
    for (const char* ext : {".tiff", ".tif", ".png"}) {
      const auto path = dir / (rc.model.id + ext);
      if (!std::filesystem::exists(path)) continue;
      RangeImage image;
      image.camera = rc.model;
      image.where = path.string();
      image.depth_mm = io::ReadDepthMap(path);
      images.push_back(std::move(image));
      break;
    }
  }
  core::Require(!images.empty(), dir.string(),
                "no depth map named <camera>.tiff or <camera>.png for any camera of the rig");
  return images;
}

}  // namespace dome::fusion
