// Silhouette fattening (seed §5) of range images and of a fused mesh, against the
// synthetic take's truth depth, camera by camera:
//   silhouette_fattening TAKE INSTANT MESH.ply DEPTH_DIR [--jump-mm J] [--threads N]
// Definitions (z-depth along the optical axis, mm, per pixel of each rig camera):
//  * contour pixels: truth pixels with a 4-neighbour more than J mm (default 150)
//    further away -- the occluding contours of the person and the bat;
//  * fat pixel: the reconstruction has a depth more than J mm in front of the truth
//    (a foreground surface painted over the background beside it);
//  * fattening width, px = fat pixels / contour pixels (how far, on average, the
//    foreground spills past its true outline).
// Sources: the range images DEPTH_DIR/<camera>.tiff (pixels with depth only) and the
// mesh reprojected into each camera by ray casting (mesh/preview.h RenderDepth). One
// JSON line: totals over all cameras for each source.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "core/json.h"
#include "io/depth_tiff.h"
#include "io/ply.h"
#include "mesh/preview.h"
#include "take/take.h"

using namespace dome;

namespace {
struct Count {
  long fat = 0, valid = 0;
};
void Tally(const cv::Mat& truth, const cv::Mat& recon, double jump, Count* c) {
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) {
      const float t = truth.at<float>(y, x), r = recon.at<float>(y, x);
      if (!(r > 0) || !(t > 0)) continue;
      ++c->valid;
      if (r < t - jump) ++c->fat;
    }
  }
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr,
                 "usage: silhouette_fattening TAKE INSTANT MESH.ply DEPTH_DIR [--jump-mm J] "
                 "[--threads N]\n");
    return 2;
  }
  double jump = 150.0;
  int threads = 2;
  for (int a = 5; a + 1 < argc; a += 2) {
    if (std::string(argv[a]) == "--jump-mm") jump = std::atof(argv[a + 1]);
    if (std::string(argv[a]) == "--threads") threads = std::atoi(argv[a + 1]);
  }
  try {
    const take::Take take = take::OpenTake(argv[1]);
    const std::string instant = argv[2];
    const io::Mesh mesh = io::ReadPly(argv[3]);
    const std::filesystem::path depth_dir = argv[4];
    long contour = 0;
    Count stereo, fused;
    int cameras = 0;
    for (const auto& rc : take.rig.cameras) {
      const auto path = depth_dir / (rc.model.id + ".tiff");
      if (!std::filesystem::exists(path)) continue;
      ++cameras;
      const cv::Mat truth = io::ReadDepthTiff(take.TruthDepthPath(instant, rc.model.id));
      for (int y = 0; y < truth.rows; ++y) {
        for (int x = 0; x < truth.cols; ++x) {
          const float t = truth.at<float>(y, x);
          if (!(t > 0)) continue;
          bool edge = false;
          const int dx[4] = {1, -1, 0, 0}, dy[4] = {0, 0, 1, -1};
          for (int k = 0; k < 4 && !edge; ++k) {
            const int u = x + dx[k], v = y + dy[k];
            if (u < 0 || v < 0 || u >= truth.cols || v >= truth.rows) continue;
            const float n = truth.at<float>(v, u);
            edge = !(n > 0) || n > t + jump;
          }
          contour += edge;
        }
      }
      Tally(truth, io::ReadDepthMap(path), jump, &stereo);
      Tally(truth, mesh::RenderDepth(mesh, rc.model, threads), jump, &fused);
    }
    auto src = [&](const Count& c) -> core::Json {
      return {{"fat_px", c.fat},
              {"valid_px", c.valid},
              {"fat_fraction", c.valid ? double(c.fat) / c.valid : 0.0},
              {"fattening_width_px", contour ? double(c.fat) / contour : 0.0}};
    };
    core::PrintJsonLine({{"cameras", cameras},
                         {"jump_mm", jump},
                         {"contour_px", contour},
                         {"range_images", src(stereo)},
                         {"fused_mesh", src(fused)}});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "silhouette_fattening: %s\n", e.what());
    return 1;
  }
  return 0;
}
