// Helpers shared by the io and eval tests, and a TIFF writer for the io tests (the
// temporary folder and the InputError check come from tests/testing/).
#pragma once

#include <gtest/gtest.h>
#include <tiffio.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "core/error.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::testing {

inline bool RunningAsRoot() { return ::geteuid() == 0; }

// Writes a TIFF with libtiff directly (to make files dome would never write).
inline void WriteRawTiff(const std::filesystem::path& path, int width, int height, int spp, int bps,
                         int sample_format, const void* data, bool tiled = false) {
  TIFF* t = TIFFOpen(path.c_str(), "w");
  ASSERT_NE(t, nullptr);
  TIFFSetField(t, TIFFTAG_IMAGEWIDTH, width);
  TIFFSetField(t, TIFFTAG_IMAGELENGTH, height);
  TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, spp);
  TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, bps);
  TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, sample_format);
  TIFFSetField(t, TIFFTAG_PHOTOMETRIC, spp == 3 ? PHOTOMETRIC_RGB : PHOTOMETRIC_MINISBLACK);
  TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
  const size_t row_bytes = static_cast<size_t>(width) * spp * bps / 8;
  const auto* bytes = static_cast<const uint8_t*>(data);
  if (tiled) {
    TIFFSetField(t, TIFFTAG_TILEWIDTH, 16);
    TIFFSetField(t, TIFFTAG_TILELENGTH, 16);
    const size_t px = static_cast<size_t>(spp) * bps / 8;
    std::vector<uint8_t> tile(16 * 16 * px);
    for (int ty = 0; ty < height; ty += 16) {
      for (int tx = 0; tx < width; tx += 16) {
        std::fill(tile.begin(), tile.end(), 0);
        for (int r = 0; r < 16 && ty + r < height; ++r) {
          for (int c = 0; c < 16 && tx + c < width; ++c) {
            std::memcpy(&tile[(r * 16 + c) * px], bytes + (ty + r) * row_bytes + (tx + c) * px, px);
          }
        }
        ASSERT_GE(TIFFWriteTile(t, tile.data(), tx, ty, 0, 0), 0);
      }
    }
  } else {
    std::vector<uint8_t> row(row_bytes);
    for (int y = 0; y < height; ++y) {
      std::memcpy(row.data(), bytes + y * row_bytes, row_bytes);
      ASSERT_EQ(TIFFWriteScanline(t, row.data(), y, 0), 1);
    }
  }
  TIFFClose(t);
}

}  // namespace dome::testing
