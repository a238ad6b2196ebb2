// Depth-map files.
//
// A depth map is a cv::Mat of type CV_32FC1, one value per pixel of the reference
// camera's image: z-depth along the camera's optical axis (camera frame +z, not the
// Euclidean ray length) in millimetres; 0 means "no surface / invalid". Valid depths
// are finite and > 0; NaN, infinities and negative values are never stored.
//
// Formats:
//  * Float TIFF (the lossless working format): baseline TIFF, one sample per pixel,
//    BitsPerSample 32, SampleFormat IEEEFP (3), Photometric MinIsBlack, strips,
//    ImageDescription "dome depth map: z along the optical axis in mm, 0 = invalid";
//    compressed by the DepthTiffEncoding below (Deflate with the floating-point
//    predictor, or PackBits: both baseline-readable). Written with
//    libtiff directly so the sample format tag is always right; readable by libtiff,
//    OpenCV (IMREAD_UNCHANGED -> CV_32FC1), GDAL, tifffile. On read any
//    compression/tiling libtiff knows is accepted, but the file must be
//    1-channel 32-bit float and every value finite and >= 0.
//  * 16-bit PNG (for standard viewers, SPEC "Outputs open in standard tools"): one
//    channel, unsigned 16-bit, value = depth rounded to the nearest millimetre, 0 =
//    invalid. Lossy: sub-millimetre detail is lost; depths beyond 65535 mm are
//    clamped to 65535 (a 5 m dome never gets there); valid depths below 0.5 mm are
//    written as 1 so they stay valid.
//  * Preview PNG (for eyes only): 8-bit BGR through an OpenCV colour map, near =
//    the map's high end (red for TURBO), far = low end (blue), invalid = black.
#pragma once

#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

namespace dome::io {

// Throws core::InputError naming `where` unless `depth_mm` is CV_32FC1 with every
// value finite and >= 0 (the message gives the first bad pixel as (x, y) and its value;
// `origin` is added to it when `depth_mm` is a rectangle of a larger map at `origin`).
void CheckDepthMap(const cv::Mat& depth_mm, const std::string& where, cv::Point origin = {0, 0});

// How a float TIFF depth map is compressed.
//  kSmall: Deflate (zlib's fastest level) with the floating-point predictor (3). For
//    smooth maps (a synthetic take's truth depths: 110 KB against 317 KB for 320 x 245
//    pixels).
//  kFast: PackBits (run lengths). For stereo's maps, whose depths are noisy in their low
//    bytes, so the predictor gains little, and whose empty pixels are runs: Robovision
//    cameras' maps (1280 x 1024) are encoded in 3.1-4.7 against 26-28 ms and read in
//    0.9-1.3 against 21-23 ms, 1.5x the bytes (346 against 226 KB, 1106 against 745 KB);
//    a paper camera's, mostly empty, 0.19 against 1.43 ms and 0.06 against 1.11 ms, 19
//    against 16 KB (bench/io/depth_tiff_bench.cc, medians of 20).
enum class DepthTiffEncoding { kSmall, kFast };

// Float TIFF. The writer throws core::InputError naming the file when the map is
// not a valid depth map (see CheckDepthMap) or the folder is missing / not writable.
void WriteDepthTiff(const std::filesystem::path& path, const cv::Mat& depth_mm,
                    DepthTiffEncoding encoding = DepthTiffEncoding::kSmall);
// Any 1-channel float image as a float TIFF like the depth maps' but PackBits-compressed
// (run lengths: cheap, and the zeros of a map that is mostly empty shrink to a 64th),
// with `description` as its ImageDescription; for maps beside the depth maps
// (reliability). Throws core::InputError naming `where` for an empty or non-float image.
std::string EncodeRunLengthFloatTiff(const cv::Mat& image, const std::string& description,
                                     const std::string& where);
cv::Mat ReadDepthTiff(const std::filesystem::path& path);
// The same file as bytes (the writer's file, byte for byte), and read back from bytes;
// errors name `where`.
std::string EncodeDepthTiff(const cv::Mat& depth_mm, const std::string& where,
                            DepthTiffEncoding encoding = DepthTiffEncoding::kSmall);
cv::Mat DecodeDepthTiff(std::string bytes, const std::string& where);

// 16-bit PNG in millimetres.
void WriteDepthPng16(const std::filesystem::path& path, const cv::Mat& depth_mm);
// Returns CV_32FC1 millimetres. The file must be a 1-channel 16-bit image.
cv::Mat ReadDepthPng16(const std::filesystem::path& path);

// Reads a depth map by extension: .tif/.tiff -> float TIFF, .png -> 16-bit PNG.
cv::Mat ReadDepthMap(const std::filesystem::path& path);

struct DepthPreviewOptions {
  // Depth shown at the near end of the colour map, in mm; <= 0 with far_mm <= 0
  // picks both from the valid pixels (1st and 99th percentile, so a few outliers do
  // not wash the picture out).
  double near_mm = 0.0;
  // Depth shown at the far end of the colour map, in mm.
  double far_mm = 0.0;
  // An OpenCV cv::ColormapTypes value.
  int colormap = cv::COLORMAP_TURBO;

  // Throws core::InputError naming the first bad option.
  void Check() const;
};

// Colour levels of a depth preview (plus black for no depth: a palette of 256).
constexpr int kDepthPreviewLevels = 255;

// A depth preview as palette indices (CV_8UC1, the map's size): 0 where there is no
// depth, else 1 + the depth's level, from 0 at far_mm to kDepthPreviewLevels - 1 at
// near_mm (clamped), rounded to the nearest; `palette` gets black and the levels'
// colours (evenly over the colour map, its far end first).
cv::Mat DepthPreviewIndices(const cv::Mat& depth_mm, const DepthPreviewOptions& options,
                            std::vector<cv::Vec3b>* palette);
// CV_8UC3 (BGR) preview of a depth map: the indices' colours.
cv::Mat DepthPreview(const cv::Mat& depth_mm, const DepthPreviewOptions& options = {});
void WriteDepthPreviewPng(const std::filesystem::path& path, const cv::Mat& depth_mm,
                          const DepthPreviewOptions& options = {});
// The preview PNG file's bytes (a palette PNG of the indices above: DepthPreview's
// picture when decoded).
std::string EncodeDepthPreviewPng(const cv::Mat& depth_mm, const std::string& where,
                                  const DepthPreviewOptions& options = {});

}  // namespace dome::io
