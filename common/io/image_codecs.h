// Image files decoded and encoded with the format libraries themselves: libpng,
// libjpeg-turbo, libtiff (io's own; image_io.h is the interface).
//
// Why not OpenCV's imgcodecs: Debian's build of it links GDAL, GDCM, OpenEXR, OpenJPEG,
// libheif and their dependencies, 139 shared libraries, which every dome program loaded
// and relocated at start-up (most of a worker's or the master's 0.13 s) for the three
// formats a camera gives. The pixels are those OpenCV's imdecode(IMREAD_UNCHANGED) gives
// for the same file (checked against it in tests/io/image_codecs_test.cc), and PNGs are
// encoded with the settings OpenCV used, so files written before and after are the same.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <vector>

namespace dome::io::codecs {

// The image as stored, in OpenCV's channel order: 8- or 16-bit (32-bit float for a float
// TIFF), 1, 3 or 4 channels; a palette becomes BGR (BGRA when it has transparency), grey
// below 8 bits becomes 8-bit, a PNG's grey + alpha becomes BGRA, a TIFF's stays 2
// channels. EXIF orientation is not applied. The format comes from the first bytes:
//  - PNG (every colour type and depth, interlaced or not);
//  - JPEG (baseline and progressive, grey or YCbCr; CMYK is refused);
//  - TIFF (the first image: 8/16-bit unsigned or 32-bit float grey or RGB(A), strips or
//    tiles; other layouts -- palette, YCbCr, 1-bit, CMYK -- through libtiff's RGBA reader
//    as 8-bit);
//  - BMP (uncompressed 1/4/8-bit palette, 24 and 32-bit).
// Throws core::InputError naming `where`: not an image of these formats, corrupt or
// truncated data (JPEG excepted: libjpeg fills a truncated JPEG with grey), or a size
// above 2^28 pixels.
cv::Mat Decode(std::string_view bytes, const std::string& where);

// PNG of an 8- or 16-bit image with 1, 3 or 4 channels (BGR order). small: each row's best
// filter, zlib level 3, default strategy; otherwise the Sub filter, zlib level 1,
// run-length matches only (see PngEncoding in image_io.h).
std::string EncodePng(const cv::Mat& image, bool small);

// PNG of palette indices (CV_8UC1) and their colours (BGR, 1 to 256 of them; every
// index below palette.size()): colour type 3, 8 bits an index, the filter and zlib
// settings of EncodePng. Decode gives the colours back (BGR).
std::string EncodePalettePng(const cv::Mat& indices, const std::vector<cv::Vec3b>& palette,
                             bool small);

}  // namespace dome::io::codecs
