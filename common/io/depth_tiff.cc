#include "io/depth_tiff.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <vector>

#include "core/error.h"
#include "io/file_util.h"
#include "io/image_io.h"
#include "io/tiff_memory.h"

namespace dome::io {
namespace {

constexpr char kDescription[] = "dome depth map: z along the optical axis in mm, 0 = invalid";
// Guards against headers that claim absurd sizes (corrupt or hostile files).
constexpr int64_t kMaxSide = 1 << 18;
constexpr int64_t kMaxPixels = int64_t{1} << 30;

std::string FormatValue(float v) {
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%g", static_cast<double>(v));
  return buf;
}

TiffHandle OpenTiff(MemoryFile* file, const char* mode, TiffMessages* messages) {
  return OpenMemoryTiff(file, mode, "depth map", kMaxPixels * 4, messages);
}

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

const char* SampleFormatName(uint16_t f) {
  switch (f) {
    case SAMPLEFORMAT_UINT:
      return "unsigned integer";
    case SAMPLEFORMAT_INT:
      return "signed integer";
    case SAMPLEFORMAT_IEEEFP:
      return "float";
    default:
      return "other";
  }
}

}  // namespace

void CheckDepthMap(const cv::Mat& depth_mm, const std::string& where, cv::Point origin) {
  core::Require(depth_mm.type() == CV_32FC1, where,
                "depth map must be single-channel 32-bit float (CV_32FC1) in mm");
  for (int y = 0; y < depth_mm.rows; ++y) {
    const float* row = depth_mm.ptr<float>(y);
    // A float is finite and >= 0 (-0 included) exactly when its bit pattern, unsigned,
    // is at most the largest finite float's or is -0's: a comparison without a branch
    // per pixel, which vectorizes (this file is built at -O3). A depth map is checked
    // wherever it crosses a boundary (encoded, decoded, cut, fused: about seven times
    // per stereo job), so the rows go at vector speed and only a row with a bad pixel
    // is searched again for the first one.
    uint32_t bad = 0;
    for (int x = 0; x < depth_mm.cols; ++x) {
      uint32_t bits;
      std::memcpy(&bits, row + x, sizeof(bits));
      bad |= uint32_t(bits > 0x7f7fffffu) & uint32_t(bits != 0x80000000u);
    }
    if (bad == 0) continue;
    for (int x = 0; x < depth_mm.cols; ++x) {
      const float v = row[x];
      // One comparison for the common case; NaN fails it too.
      if (!(v >= 0.0f && v <= std::numeric_limits<float>::max())) {
        throw core::InputError(where, "depth at pixel (" + std::to_string(origin.x + x) + ", " +
                                          std::to_string(origin.y + y) + ") is " + FormatValue(v) +
                                          "; depths must be finite and >= 0 mm (0 = invalid)");
      }
    }
  }
}

namespace {

// One float sample per pixel, strips; Deflate (fastest level) with the floating-point
// predictor, or PackBits.
std::string EncodeFloatTiffWith(const cv::Mat& m, bool deflate, const char* description,
                                const std::string& where) {
  TiffMessages messages;
  MemoryFile file;
  {
    TiffHandle tif = OpenTiff(&file, "w", &messages);
    core::Require(tif != nullptr, where, "cannot start a TIFF: " + messages.error);
    TIFF* t = tif.get();
    deflate = deflate && TIFFIsCODECConfigured(COMPRESSION_ADOBE_DEFLATE) != 0;
    TIFFSetField(t, TIFFTAG_IMAGEWIDTH, static_cast<uint32_t>(m.cols));
    TIFFSetField(t, TIFFTAG_IMAGELENGTH, static_cast<uint32_t>(m.rows));
    TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, uint16_t{1});
    TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, uint16_t{32});
    TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, uint16_t{SAMPLEFORMAT_IEEEFP});
    TIFFSetField(t, TIFFTAG_PHOTOMETRIC, uint16_t{PHOTOMETRIC_MINISBLACK});
    TIFFSetField(t, TIFFTAG_PLANARCONFIG, uint16_t{PLANARCONFIG_CONTIG});
    TIFFSetField(t, TIFFTAG_COMPRESSION,
                 static_cast<uint16_t>(deflate ? COMPRESSION_ADOBE_DEFLATE : COMPRESSION_PACKBITS));
    // Floating-point predictor: byte-plane differencing, which makes smooth depth
    // surfaces compress well under Deflate.
    if (deflate) {
      TIFFSetField(t, TIFFTAG_PREDICTOR, uint16_t{PREDICTOR_FLOATINGPOINT});
      // zlib's fastest level: level 6 costs several times the CPU for files only a
      // few percent smaller.
      TIFFSetField(t, TIFFTAG_ZIPQUALITY, 1);
    }
    TIFFSetField(t, TIFFTAG_ROWSPERSTRIP, TIFFDefaultStripSize(t, 0));
    TIFFSetField(t, TIFFTAG_IMAGEDESCRIPTION, description);
    TIFFSetField(t, TIFFTAG_SOFTWARE, "dome");
    std::vector<float> row(m.cols);
    bool ok = true;
    for (int y = 0; y < m.rows && ok; ++y) {
      std::memcpy(row.data(), m.ptr<float>(y), row.size() * sizeof(float));
      ok = TIFFWriteScanline(t, row.data(), static_cast<uint32_t>(y), 0) == 1;
    }
    ok = ok && TIFFFlush(t) == 1;
    core::Require(ok, where, "encoding failed: " + messages.error);
  }
  return std::move(file.bytes);
}

}  // namespace

std::string EncodeDepthTiff(const cv::Mat& depth_mm, const std::string& where,
                            DepthTiffEncoding encoding) {
  CheckDepthMap(depth_mm, where);
  core::Require(!depth_mm.empty(), where, "refusing to write an empty depth map");
  return EncodeFloatTiffWith(depth_mm, /*deflate=*/encoding == DepthTiffEncoding::kSmall,
                             kDescription, where);
}

std::string EncodeRunLengthFloatTiff(const cv::Mat& image, const std::string& description,
                                     const std::string& where) {
  core::Require(!image.empty() && image.type() == CV_32FC1, where,
                "a float TIFF needs a non-empty 1-channel float image");
  return EncodeFloatTiffWith(image, /*deflate=*/false, description.c_str(), where);
}

void WriteDepthTiff(const std::filesystem::path& path, const cv::Mat& depth_mm,
                    DepthTiffEncoding encoding) {
  const std::string bytes = EncodeDepthTiff(depth_mm, path.string(), encoding);
  RequireParentFolder(path);
  WriteFileAtomically(path, bytes);
}

cv::Mat ReadDepthTiff(const std::filesystem::path& path) {
  const std::string where = path.string();
  // Let ReadFileBytes-style checks give the plain "no such file" messages.
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  core::Require(std::filesystem::exists(status), where, "no such file");
  core::Require(!std::filesystem::is_directory(status), where, "is a folder, expected a file");
  return DecodeDepthTiff(ReadFileBytes(path), where);
}

cv::Mat DecodeDepthTiff(std::string bytes, const std::string& where) {
  TiffMessages messages;
  MemoryFile file{std::move(bytes), 0};
  TiffHandle tif = OpenTiff(&file, "r", &messages);
  core::Require(tif != nullptr, where,
                "not a readable TIFF file (" +
                    (messages.error.empty() ? std::string("cannot open") : messages.error) + ")");
  TIFF* t = tif.get();
  uint32_t width = 0, height = 0;
  uint16_t spp = 1, bps = 1, sample_format = SAMPLEFORMAT_UINT;
  core::Require(TIFFGetField(t, TIFFTAG_IMAGEWIDTH, &width) == 1 &&
                    TIFFGetField(t, TIFFTAG_IMAGELENGTH, &height) == 1,
                where, "TIFF without image width/length tags");
  TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLESPERPIXEL, &spp);
  TIFFGetFieldDefaulted(t, TIFFTAG_BITSPERSAMPLE, &bps);
  TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLEFORMAT, &sample_format);
  core::Require(spp == 1 && bps == 32 && sample_format == SAMPLEFORMAT_IEEEFP, where,
                "is a " + std::to_string(spp) + "-channel " + std::to_string(bps) + "-bit " +
                    SampleFormatName(sample_format) +
                    " TIFF; a depth map must be single-channel 32-bit float (mm)");
  core::Require(width > 0 && height > 0 && width <= kMaxSide && height <= kMaxSide &&
                    int64_t{width} * height <= kMaxPixels,
                where,
                "implausible image size " + std::to_string(width) + "x" + std::to_string(height));
  cv::Mat depth(static_cast<int>(height), static_cast<int>(width), CV_32FC1);
  auto fail = [&](const std::string& what) {
    throw core::InputError(where, "corrupt TIFF data (" + what + ")" +
                                      (messages.error.empty() ? "" : ": " + messages.error));
  };
  const std::string failed = ReadTiffPixels(t, 4, &depth);
  if (!failed.empty()) fail(failed);
  CheckDepthMap(depth, where);
  return depth;
}

void WriteDepthPng16(const std::filesystem::path& path, const cv::Mat& depth_mm) {
  const std::string where = path.string();
  CheckDepthMap(depth_mm, where);
  core::Require(!depth_mm.empty(), where, "refusing to write an empty depth map");
  cv::Mat mm16(depth_mm.size(), CV_16UC1);
  for (int y = 0; y < depth_mm.rows; ++y) {
    const float* in = depth_mm.ptr<float>(y);
    uint16_t* out = mm16.ptr<uint16_t>(y);
    for (int x = 0; x < depth_mm.cols; ++x) {
      const float v = in[x];
      // Valid stays valid (>= 1); beyond the 16-bit range clamps (header comment).
      out[x] = v > 0.0f ? static_cast<uint16_t>(std::clamp(std::lround(v), 1L, 65535L)) : 0;
    }
  }
  WriteImage(path, mm16);
}

cv::Mat ReadDepthPng16(const std::filesystem::path& path) {
  const cv::Mat stored = ReadImage(path, ImageMode::kUnchanged);
  core::Require(stored.type() == CV_16UC1, path.string(),
                "a depth PNG must be single-channel 16-bit (millimetres), got " +
                    std::to_string(stored.channels()) + "-channel " +
                    (stored.depth() == CV_8U ? "8-bit" : "non-16-bit") + " data");
  cv::Mat depth;
  stored.convertTo(depth, CV_32F);
  return depth;
}

cv::Mat ReadDepthMap(const std::filesystem::path& path) {
  const std::string ext = Lower(path.extension().string());
  if (ext == ".tif" || ext == ".tiff") {
    return ReadDepthTiff(path);
  }
  if (ext == ".png") {
    return ReadDepthPng16(path);
  }
  throw core::InputError(path.string(),
                         "unknown depth map extension; expected .tif/.tiff (float mm) or "
                         ".png (16-bit mm)");
}

}  // namespace dome::io
