// png_bench: the two PNG encodings of io/image_io.h (PngEncoding::kSmall and kFast) on
// the images given, side by side: milliseconds per encode (the median of --repeats
// timed encodes each, alternating) and bytes.
//
//   png_bench IMAGE... [--repeats N]
//
// Images are read as they are (PNG, JPEG, TIFF or BMP: a take's frames, masks,
// depth previews, an atlas). Prints one line per image and encoding.
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "io/image_io.h"
#include "timed_files.h"

int main(int argc, char** argv) {
  using dome::io::PngEncoding;
  dome::bench::TimedFiles args;
  if (!dome::bench::ParseTimedFiles(argc, argv, 50, "usage: png_bench IMAGE... [--repeats N]",
                                    &args))
    return 1;
  const int repeats = args.repeats;
  for (const std::string& path : args.paths) {
    cv::Mat image;
    try {
      image = dome::io::ReadImage(path, dome::io::ImageMode::kUnchanged);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s\n", e.what());
      return 1;
    }
    std::vector<double> ms[2];
    size_t bytes[2] = {0, 0};
    for (int r = 0; r < repeats; ++r) {
      for (int e = 0; e < 2; ++e) {
        const auto t0 = std::chrono::steady_clock::now();
        const std::string png =
            dome::io::EncodePng(image, e == 0 ? PngEncoding::kSmall : PngEncoding::kFast);
        ms[e].push_back(dome::bench::MsSince(t0));
        bytes[e] = png.size();
      }
    }
    std::printf("%s (%dx%d, %d channel(s)): kSmall %.2f ms %zu bytes, kFast %.2f ms %zu bytes\n",
                path.c_str(), image.cols, image.rows, image.channels(),
                dome::bench::MedianMs(ms[0]), bytes[0], dome::bench::MedianMs(ms[1]), bytes[1]);
  }
  return 0;
}
