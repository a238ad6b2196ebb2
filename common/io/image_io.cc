#include "io/image_io.h"

#include <algorithm>
#include <cctype>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/error.h"
#include "io/file_util.h"
#include "io/image_codecs.h"

namespace dome::io {
namespace {

std::string DepthName(int depth) {
  switch (depth) {
    case CV_8U:
      return "8-bit";
    case CV_8S:
      return "8-bit signed";
    case CV_16U:
      return "16-bit";
    case CV_16S:
      return "16-bit signed";
    case CV_32S:
      return "32-bit integer";
    case CV_32F:
      return "32-bit float";
    case CV_64F:
      return "64-bit float";
    default:
      return "unknown-depth";
  }
}

std::string Describe(const cv::Mat& m) {
  return DepthName(m.depth()) + " " + std::to_string(m.channels()) + "-channel " +
         std::to_string(m.cols) + "x" + std::to_string(m.rows);
}

}  // namespace

const char* ImageModeName(ImageMode mode) {
  switch (mode) {
    case ImageMode::kGray8:
      return "gray8";
    case ImageMode::kBgr8:
      return "bgr8";
    case ImageMode::kBgra8:
      return "bgra8";
    case ImageMode::kUnchanged:
      return "unchanged";
  }
  return "?";
}

cv::Mat DecodeImage(std::string_view bytes, ImageMode mode, const std::string& where) {
  const cv::Mat stored = codecs::Decode(bytes, where);
  if (mode == ImageMode::kUnchanged) {
    return stored;
  }

  const std::string wanted = std::string(" image; asked for ") + ImageModeName(mode);
  core::Require(stored.depth() == CV_8U, where,
                "is a " + Describe(stored) + wanted + ", which needs an 8-bit file");
  const int channels = stored.channels();
  core::Require(channels >= 1 && channels <= 4, where,
                "is a " + Describe(stored) + wanted + ", which needs 1 to 4 channels");
  cv::Mat out;
  switch (mode) {
    case ImageMode::kGray8:
      if (channels == 1) {
        return stored;
      }
      if (channels == 2) {
        cv::extractChannel(stored, out, 0);
      } else {
        cv::cvtColor(stored, out, channels == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
      }
      return out;
    case ImageMode::kBgr8:
      if (channels == 3) {
        return stored;
      }
      if (channels == 2) {
        cv::extractChannel(stored, out, 0);
        cv::cvtColor(out, out, cv::COLOR_GRAY2BGR);
      } else {
        cv::cvtColor(stored, out, channels == 1 ? cv::COLOR_GRAY2BGR : cv::COLOR_BGRA2BGR);
      }
      return out;
    case ImageMode::kBgra8:
      core::Require(channels == 2 || channels == 4, where,
                    "is a " + Describe(stored) + wanted + ", which needs an alpha channel");
      if (channels == 4) {
        return stored;
      }
      {
        std::vector<cv::Mat> ga;
        cv::split(stored, ga);
        cv::merge(std::vector<cv::Mat>{ga[0], ga[0], ga[0], ga[1]}, out);
      }
      return out;
    case ImageMode::kUnchanged:
      break;
  }
  return stored;
}

cv::Mat ReadImage(const std::filesystem::path& path, ImageMode mode) {
  return DecodeImage(ReadFileBytes(path), mode, path.string());
}

PngHeader ReadPngHeader(std::string_view bytes, const std::string& where) {
  static constexpr unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  core::Require(bytes.size() >= 8 + 8 + 13 && std::memcmp(b, kSignature, 8) == 0, where,
                "is not a PNG file (no PNG signature)");
  const auto be32 = [&](size_t at) {
    return uint32_t(b[at]) << 24 | uint32_t(b[at + 1]) << 16 | uint32_t(b[at + 2]) << 8 |
           uint32_t(b[at + 3]);
  };
  core::Require(be32(8) == 13 && std::memcmp(b + 12, "IHDR", 4) == 0, where,
                "is not a PNG file (no IHDR chunk first)");
  PngHeader h;
  const uint32_t w = be32(16), ht = be32(20);
  core::Require(w > 0 && ht > 0 && w <= (1u << 24) && ht <= (1u << 24), where,
                "PNG of implausible size " + std::to_string(w) + "x" + std::to_string(ht));
  h.width = int(w);
  h.height = int(ht);
  h.bit_depth = b[24];
  h.colour_type = b[25];
  return h;
}

std::string EncodePng(const cv::Mat& image, PngEncoding encoding) {
  DOME_CHECK(!image.empty(), "EncodePng: empty image");
  DOME_CHECK(image.depth() == CV_8U || image.depth() == CV_16U,
             "EncodePng: PNG holds 8- or 16-bit samples, got " + Describe(image));
  DOME_CHECK(image.channels() == 1 || image.channels() == 3 || image.channels() == 4,
             "EncodePng: PNG holds 1, 3 or 4 channels, got " + Describe(image));
  // kSmall: each row's best filter at zlib level 3 costs a fraction of the time of the
  // 9-ish levels for ~5 % larger files. kFast: see PngEncoding.
  return codecs::EncodePng(image, encoding == PngEncoding::kSmall);
}

std::string EncodePalettePng(const cv::Mat& indices, const std::vector<cv::Vec3b>& palette,
                             PngEncoding encoding) {
  return codecs::EncodePalettePng(indices, palette, encoding == PngEncoding::kSmall);
}

namespace {

// WriteImage's checks of where a PNG goes: a .png path whose folder exists.
void CheckPngPath(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  core::Require(ext == ".png", path.string(), "images are written as PNG; expected a .png path");
  RequireParentFolder(path);
}

}  // namespace

void WriteImage(const std::filesystem::path& path, const cv::Mat& image, PngEncoding encoding) {
  CheckPngPath(path);
  WriteFileAtomically(path, EncodePng(image, encoding));
}

void WritePaletteImage(const std::filesystem::path& path, const cv::Mat& indices,
                       const std::vector<cv::Vec3b>& palette, PngEncoding encoding) {
  CheckPngPath(path);
  WriteFileAtomically(path, EncodePalettePng(indices, palette, encoding));
}

}  // namespace dome::io
