// depth_tiff_bench: the two float-TIFF encodings of a depth map (io/depth_tiff.h
// DepthTiffEncoding::kSmall and kFast) on the maps given, side by side: milliseconds to
// encode and to decode (the median of --repeats timed runs each, the encodings
// alternating) and bytes. Each decoded map is checked against the input, bit for bit.
// Also the milliseconds of io::CheckDepthMap on the map (its median), which every map
// goes through several times on its way from a stereo job to fusion.
//
//   depth_tiff_bench DEPTH.tiff... [--repeats N]
//
// Maps are read with io::ReadDepthTiff (a run's OUT/<instant>/depth/<camera>.tiff, a
// synthetic take's truth depths). Prints one line per map.
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
  using dome::io::DepthTiffEncoding;
  dome::bench::TimedFiles args;
  if (!dome::bench::ParseTimedFiles(argc, argv, 20,
                                    "usage: depth_tiff_bench DEPTH.tiff... [--repeats N]", &args))
    return 1;
  const DepthTiffEncoding encodings[2] = {DepthTiffEncoding::kSmall, DepthTiffEncoding::kFast};
  for (const std::string& path : args.paths) {
    const cv::Mat depth = dome::io::ReadDepthTiff(path);
    std::vector<double> encode_ms[2], decode_ms[2], check_ms;
    size_t bytes[2] = {0, 0};
    for (int r = 0; r < args.repeats; ++r) {
      auto checked = std::chrono::steady_clock::now();
      dome::io::CheckDepthMap(depth, path);
      check_ms.push_back(MsSince(checked));
      for (int e = 0; e < 2; ++e) {
        auto t0 = std::chrono::steady_clock::now();
        const std::string tiff = dome::io::EncodeDepthTiff(depth, path, encodings[e]);
        encode_ms[e].push_back(MsSince(t0));
        bytes[e] = tiff.size();
        t0 = std::chrono::steady_clock::now();
        const cv::Mat back = dome::io::DecodeDepthTiff(tiff, path);
        decode_ms[e].push_back(MsSince(t0));
        if (back.size() != depth.size() || cv::norm(back, depth, cv::NORM_INF) != 0.0) {
          std::fprintf(stderr, "%s: the decoded map differs from the input\n", path.c_str());
          return 1;
        }
      }
    }
    std::printf(
        "%s (%dx%d): kSmall encode %.2f ms decode %.2f ms %zu bytes, kFast encode "
        "%.2f ms decode %.2f ms %zu bytes, check %.3f ms\n",
        path.c_str(), depth.cols, depth.rows, MedianMs(encode_ms[0]), MedianMs(decode_ms[0]),
        bytes[0], MedianMs(encode_ms[1]), MedianMs(decode_ms[1]), bytes[1], MedianMs(check_ms));
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return dome::bench::GuardedMain("depth_tiff_bench", Run, argc, argv);
}
