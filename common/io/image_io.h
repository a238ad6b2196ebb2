// Reading and writing 8-bit images (camera frames, textures, previews).
//
// Images are cv::Mat in OpenCV's channel order (BGR / BGRA). Pixels come back as
// stored in the file: EXIF orientation is *not* applied, because calibration and
// stereo need the sensor's own pixel grid.
//
// Errors are core::InputError naming the file: missing, unreadable, not a decodable
// image (corrupt or truncated), or a bit depth / channel count that cannot give what
// was asked. JPEG decoders fill a truncated JPEG with grey instead of failing, so
// truncation is only detected for formats whose decoders report it (PNG, TIFF).
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <vector>

namespace dome::io {

enum class ImageMode {
  // CV_8UC1. Accepts 8-bit gray, gray+alpha, BGR or BGRA files; colour is converted
  // with the ITU-R 601 weights (exact when R = G = B, as in the Robovision frames),
  // alpha is dropped.
  kGray8,
  // CV_8UC3 (BGR). Accepts 8-bit files with 1-4 channels; gray is replicated, alpha
  // dropped.
  kBgr8,
  // CV_8UC4 (BGRA), alpha kept. The file must have an alpha channel (8-bit
  // gray+alpha or RGBA): callers ask for alpha because it marks valid pixels, so a
  // file without one is an error rather than silently opaque.
  kBgra8,
  // As stored: any depth (8/16-bit, float) and channel count. For 16-bit depth PNGs.
  kUnchanged,
};

// "gray8", "bgr8", "bgra8", "unchanged": for messages.
const char* ImageModeName(ImageMode mode);

// Reads `path`: PNG, JPEG, TIFF or BMP (io/image_codecs.h says which kinds of each).
cv::Mat ReadImage(const std::filesystem::path& path, ImageMode mode);

// Decodes an encoded image held in memory (e.g. a blob received from a peer);
// `where` names its source in errors.
cv::Mat DecodeImage(std::string_view bytes, ImageMode mode, const std::string& where);

// What a PNG file's header (signature and IHDR chunk) says, without decoding it: for
// checking a PNG received from a peer cheaply. Throws core::InputError naming `where`
// when the bytes do not start as a PNG.
struct PngHeader {
  int width = 0, height = 0;
  int bit_depth = 0;
  int colour_type = 0;  // 0 grey, 2 RGB, 3 palette, 4 grey + alpha, 6 RGBA
};
PngHeader ReadPngHeader(std::string_view bytes, const std::string& where);

// How a PNG is encoded.
//  kSmall: each row's best of the five PNG filters, zlib level 3. For photographs
//    (frames of real cameras, imported or captured) and images delivered to users
//    (texture atlases), where the bytes matter.
//  kFast: every row with the Sub filter, zlib level 1 with run-length matches only
//    (OpenCV's speed settings; the filter search, not zlib, was kSmall's time). For
//    pictures with flat areas (masks, depth previews, synthetic frames): 2-4x faster
//    for about the same bytes (a paper take's frame 2 % larger, its masks and depth
//    previews smaller); a photograph is 35-70 % larger (a Panoptic HD frame 3.0 against
//    2.2 MB, a Robovision frame 1.0 against 0.6 MB). bench/io/png_bench.cc measures both.
enum class PngEncoding { kSmall, kFast };

// PNG encoding of an 8- or 16-bit image with 1, 3 or 4 channels (BGR order). Other
// types are a programmer error (DOME_CHECK).
std::string EncodePng(const cv::Mat& image, PngEncoding encoding = PngEncoding::kSmall);

// PNG of a palette image: `indices` CV_8UC1, each below palette.size(); `palette` 1 to 256
// BGR colours. A third of the bytes a BGR image of those colours has to compress, for
// the same picture (ReadImage/DecodeImage give the BGR image). Other inputs are a
// programmer error (DOME_CHECK).
std::string EncodePalettePng(const cv::Mat& indices, const std::vector<cv::Vec3b>& palette,
                             PngEncoding encoding = PngEncoding::kSmall);

// Writes `image` as PNG to `path` (which must end in .png), atomically. Throws
// core::InputError naming the file when the folder is missing or not writable.
void WriteImage(const std::filesystem::path& path, const cv::Mat& image,
                PngEncoding encoding = PngEncoding::kSmall);
// The same for a palette image (EncodePalettePng).
void WritePaletteImage(const std::filesystem::path& path, const cv::Mat& indices,
                       const std::vector<cv::Vec3b>& palette,
                       PngEncoding encoding = PngEncoding::kSmall);

}  // namespace dome::io
