// depth_preview_bench: the colour-mapped preview of depth maps (io/depth_tiff.h
// DepthPreview, the pass every stereo job runs for OUT/<instant>/preview/): milliseconds
// to colour-map each map and to make its PNG file (the median of --repeats timed runs
// each), and the sum over the maps given -- an instant's previews when given one
// instant's maps.
//
//   depth_preview_bench DEPTH.tiff... [--repeats N]
//
// Maps are read with io::ReadDepthMap (a run's OUT/<instant>/depth/<camera>.tiff, a
// synthetic take's truth depths). Prints one line per map, then the sums.
#include <chrono>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "io/depth_tiff.h"
#include "timed_files.h"

namespace {

int Run(int argc, char** argv) {
  using dome::bench::MedianMs;
  using dome::bench::MsSince;
  dome::bench::TimedFiles args;
  if (!dome::bench::ParseTimedFiles(argc, argv, 20,
                                    "usage: depth_preview_bench DEPTH.tiff... [--repeats N]",
                                    &args))
    return 1;
  double map_sum = 0.0, png_sum = 0.0;
  for (const std::string& path : args.paths) {
    const cv::Mat depth = dome::io::ReadDepthMap(path);
    std::vector<double> map_ms, png_ms;
    size_t bytes = 0;
    for (int r = 0; r < args.repeats; ++r) {
      auto t0 = std::chrono::steady_clock::now();
      const cv::Mat preview = dome::io::DepthPreview(depth);
      map_ms.push_back(MsSince(t0));
      if (preview.size() != depth.size() || preview.type() != CV_8UC3) {
        std::fprintf(stderr, "%s: the preview is not a BGR image of the map's size\n",
                     path.c_str());
        return 1;
      }
      t0 = std::chrono::steady_clock::now();
      bytes = dome::io::EncodeDepthPreviewPng(depth, path).size();
      png_ms.push_back(MsSince(t0));
    }
    map_sum += MedianMs(map_ms);
    png_sum += MedianMs(png_ms);
    std::printf("%s (%dx%d): colour map %.3f ms, PNG file %.3f ms %zu bytes\n", path.c_str(),
                depth.cols, depth.rows, MedianMs(map_ms), MedianMs(png_ms), bytes);
  }
  std::printf("%zu map(s): colour maps %.2f ms, PNG files %.2f ms (sums of the medians)\n",
              args.paths.size(), map_sum, png_sum);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return dome::bench::GuardedMain("depth_preview_bench", Run, argc, argv);
}
