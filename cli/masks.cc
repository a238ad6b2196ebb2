// `dome masks TAKE [--out DIR] [--previews]`: the foreground masks of every camera and
// instant (silhouette/take_masks.h), written for inspection as DIR/<instant>/<camera>.png
// (255 = foreground); with --previews also DIR/preview/<instant>/<camera>.png, the frame
// darkened outside the mask with its outline (at most 960 pixels wide). Prints per camera
// where its masks came from and the fraction of foreground (for a median background also
// how much of it the instants agreed on and how much the fill chose), and, where the take has truth
// masks (TAKE/truth/<instant>/mask/<camera>.png, synthetic takes), the intersection over
// union with them.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "core/error.h"
#include "core/parallel_for.h"
#include "io/image_io.h"
#include "silhouette/take_masks.h"
#include "take/take.h"

namespace dome::cli {

namespace fs = std::filesystem;

void AddMasksCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand(
      "masks",
      "Foreground masks per camera and instant: given, from background plates, or "
      "from the median over the instants");
  struct Args {
    std::string take, out;
    bool previews = false;
    int threads = 0;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("TAKE", a->take, "take folder")->required();
  cmd->add_option("--out", a->out, "output folder (default TAKE/masks-derived)");
  cmd->add_flag("--previews", a->previews,
                "also write preview/<instant>/<camera>.png: the frame with the mask outlined");
  cmd->add_option("--threads", a->threads, "threads, one camera each (0 = all)")
      ->capture_default_str();
  cmd->callback([=] {
    silhouette::TakeMasks masks(take::OpenTake(a->take), silhouette::MaskOptions{});
    const take::Take& take = masks.take();
    const fs::path out = a->out.empty() ? take.dir / "masks-derived" : fs::path(a->out);
    std::error_code ec;
    // Given masks are inputs: writing over them would lose them.
    core::Require(fs::weakly_canonical(out, ec) != fs::weakly_canonical(take.dir / "masks", ec),
                  out.string(), "is the take's given masks folder: give another --out");
    const auto& cameras = take.rig.cameras;
    const int n = static_cast<int>(cameras.size());
    std::vector<std::vector<silhouette::MaskInfo>> infos(n);
    std::vector<std::vector<double>> ious(n);
    core::ParallelFor(0, n, a->threads, [&](int64_t begin, int64_t end) {
      for (int64_t c = begin; c < end; ++c) {
        const std::string& id = cameras[c].model.id;
        for (const auto& instant : take.instants) {
          silhouette::MaskInfo info;
          const cv::Mat mask = masks.Mask(instant, id, &info);
          fs::create_directories(out / instant, ec);
          io::WriteImage(out / instant / (id + ".png"), mask, io::PngEncoding::kFast);
          if (a->previews) {
            const cv::Mat frame =
                silhouette::ReadFrame(take.FramePath(instant, id), mask.size(), id).colour;
            cv::Mat preview = silhouette::MaskPreview(frame, mask);
            if (preview.cols > 960) {
              const double s = 960.0 / preview.cols;
              cv::resize(preview, preview, cv::Size(), s, s, cv::INTER_AREA);
            }
            fs::create_directories(out / "preview" / instant, ec);
            io::WriteImage(out / "preview" / instant / (id + ".png"), preview);
          }
          infos[c].push_back(info);
          const fs::path truth = take.dir / "truth" / instant / "mask" / (id + ".png");
          if (fs::exists(truth, ec)) {
            const cv::Mat t = io::ReadImage(truth, io::ImageMode::kGray8);
            core::Require(t.size() == mask.size(), truth.string(),
                          "truth mask of another size than the camera's images");
            ious[c].push_back(silhouette::MaskIoU(mask, t));
          }
        }
      }
    });
    std::printf("masks of %d camera(s) x %zu instant(s) in %s\n", n, take.instants.size(),
                out.string().c_str());
    std::vector<double> all_ious;
    for (int c = 0; c < n; ++c) {
      double sum = 0, lo = 1, hi = 0;
      for (const auto& info : infos[c]) {
        sum += info.fraction;
        lo = std::min(lo, info.fraction);
        hi = std::max(hi, info.fraction);
      }
      const auto& first = infos[c].front();
      std::string noise;
      for (double s : first.stats.sigma)
        noise += (noise.empty() ? "" : "/") + std::to_string(s).substr(0, 4);
      std::printf("  %-14s %-6s foreground %5.1f%% (%.1f..%.1f%%)", cameras[c].model.id.c_str(),
                  silhouette::MaskSourceName(first.source), 100.0 * sum / infos[c].size(),
                  100.0 * lo, 100.0 * hi);
      if (first.source != silhouette::MaskSource::kGiven) {
        std::printf("  noise %s levels, gain %.3f (first instant)", noise.c_str(),
                    first.stats.gain);
      }
      if (first.source == silhouette::MaskSource::kMedian) {
        const silhouette::ConsensusStats b = masks.BackgroundConsensus(cameras[c].model.id);
        std::printf("  background: %.1f%% agreed, %.1f%% from the fill", 100.0 * b.settled_fraction,
                    100.0 * b.changed_fraction);
      }
      if (!ious[c].empty()) {
        double iou_sum = 0, iou_min = 1;
        for (double v : ious[c]) {
          iou_sum += v;
          iou_min = std::min(iou_min, v);
        }
        std::printf("  IoU vs truth mean %.4f min %.4f", iou_sum / ious[c].size(), iou_min);
        all_ious.insert(all_ious.end(), ious[c].begin(), ious[c].end());
      }
      std::printf("\n");
    }
    if (!all_ious.empty()) {
      double sum = 0;
      for (double v : all_ious) sum += v;
      std::printf("IoU vs truth over %zu masks: mean %.4f, min %.4f\n", all_ious.size(),
                  sum / all_ious.size(), *std::min_element(all_ious.begin(), all_ious.end()));
    }
    *exit_code = 0;
  });
}

}  // namespace dome::cli
