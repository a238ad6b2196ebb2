// TIFF files held in memory, for libtiff (io's own helper; not part of io's interface).
//
// libtiff reads and writes through these callbacks, so an image can be encoded on one
// machine and written (or checked) on another. Its messages are collected per handle
// (libtiff >= 4.5) instead of printed, so the first error can go into an InputError and
// several threads can decode at once.
#pragma once

#include <tiffio.h>

#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>

namespace dome::io {

// The first error libtiff reported for a handle (the most specific one); warnings are
// dropped.
struct TiffMessages {
  std::string error;
};

struct TiffCloser {
  void operator()(TIFF* tif) const { TIFFClose(tif); }
};
using TiffHandle = std::unique_ptr<TIFF, TiffCloser>;

// A TIFF file in memory and the position libtiff is at in it.
struct MemoryFile {
  std::string bytes;
  toff_t pos = 0;
};

// Opens `file` ("r" or "w" as for TIFFOpen); `name` is what libtiff calls it. A single
// allocation above `max_alloc_bytes` is refused (a corrupt or hostile header). nullptr
// when libtiff cannot open it; messages->error then says why.
TiffHandle OpenMemoryTiff(MemoryFile* file, const char* mode, const char* name,
                          int64_t max_alloc_bytes, TiffMessages* messages);

// Reads the open image's pixels, stored interleaved (PLANARCONFIG_CONTIG) at
// `pixel_bytes` a pixel, from its tiles or strips into `out`, allocated by the caller at
// the image's size with rows of width x pixel_bytes. Returns "" or what failed ("bad tile
// geometry", "tile at (x, y)", "bad scanline size", "row y").
std::string ReadTiffPixels(TIFF* tif, size_t pixel_bytes, cv::Mat* out);

}  // namespace dome::io
