// dome's image decoders and PNG encoder (io/image_codecs.h) against OpenCV's imgcodecs,
// which they replace: the same pixels from the same files, real and made here in every
// layout OpenCV writes, and the same PNG bytes.
#include "io/image_codecs.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "io/file_util.h"
#include "io/image_io.h"
#include "test_util.h"

namespace dome::io {
namespace {

using ::dome::testing::ExpectInputError;

const std::filesystem::path kData = std::filesystem::path(DOME_SHARED_DIR) / "data";

bool Same(const cv::Mat& a, const cv::Mat& b) {
  return a.type() == b.type() && a.size() == b.size() &&
         (a.empty() || cv::norm(a, b, cv::NORM_INF) == 0);
}

std::string Bytes(const std::vector<uchar>& v) { return std::string(v.begin(), v.end()); }

// Smooth random content (so JPEG and PNG filters see something like a picture).
cv::Mat Picture(int rows, int cols, int type, unsigned seed) {
  cv::Mat noise(rows / 4 + 1, cols / 4 + 1, type);
  cv::RNG rng(seed);
  const double top = CV_MAT_DEPTH(type) == CV_16U ? 65535 : CV_MAT_DEPTH(type) == CV_32F ? 1 : 255;
  rng.fill(noise, cv::RNG::UNIFORM, 0, top);
  cv::Mat out;
  cv::resize(noise, out, cv::Size(cols, rows), 0, 0, cv::INTER_LINEAR);
  return out;
}

TEST(ImageCodecs, RealFilesDecodeAsOpenCvDecodesThem) {
  const std::vector<std::filesystem::path> files = {
      kData / "robovision/2016_10_24__17_43_02/image_camera01.png",  // RGBA PNG
      kData / "middlebury-mv/templeSparseRing/templeSR0001.png",     // RGB PNG
      kData / "middlebury-aloe/aloeGT.png",                          // grey PNG
      kData / "middlebury-aloe/aloeL.jpg",                           // colour JPEG
      kData / "chessboards/left01.jpg",                              // grey JPEG
      kData / "epfl-terrace/terrace1-c0.jpg",
  };
  int checked = 0;
  for (const auto& path : files) {
    if (!std::filesystem::exists(path)) continue;
    SCOPED_TRACE(path.string());
    const cv::Mat ours = ReadImage(path, ImageMode::kUnchanged);
    const cv::Mat theirs = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
    EXPECT_TRUE(Same(ours, theirs)) << ours.type() << " " << theirs.type();
    ++checked;
  }
  // A Panoptic HD frame (4:2:0 colour JPEG, 1920x1080).
  const auto hd = kData / "panoptic/hd";
  if (std::filesystem::exists(hd)) {
    for (const auto& cam : std::filesystem::directory_iterator(hd)) {
      for (const auto& f : std::filesystem::directory_iterator(cam.path())) {
        const cv::Mat ours = ReadImage(f.path(), ImageMode::kUnchanged);
        EXPECT_TRUE(Same(ours, cv::imread(f.path().string(), cv::IMREAD_UNCHANGED))) << f.path();
        ++checked;
        break;
      }
      break;
    }
  }
  if (checked == 0) GTEST_SKIP() << "no shared data";
}

TEST(ImageCodecs, EveryLayoutOpenCvWritesDecodesTheSame) {
  struct Case {
    const char* ext;
    int type;
    std::vector<int> params;
  };
  const std::vector<Case> cases = {
      {".png", CV_8UC1, {}},
      {".png", CV_8UC3, {}},
      {".png", CV_8UC4, {}},
      {".png", CV_16UC1, {}},
      {".png", CV_16UC3, {}},
      {".png", CV_16UC4, {}},
      {".png", CV_8UC1, {cv::IMWRITE_PNG_BILEVEL, 1}},  // 1-bit grey
      {".jpg", CV_8UC1, {}},
      {".jpg", CV_8UC3, {cv::IMWRITE_JPEG_QUALITY, 80}},
      {".jpg", CV_8UC3, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}},
      {".tif", CV_8UC1, {}},
      {".tif", CV_8UC3, {}},
      {".tif", CV_8UC4, {}},
      {".tif", CV_16UC1, {}},
      {".tif", CV_16UC3, {}},
      {".tif", CV_32FC1, {}},
      {".tif", CV_8UC3, {cv::IMWRITE_TIFF_COMPRESSION, 1}},  // uncompressed
      {".bmp", CV_8UC1, {}},                                 // grey palette
      {".bmp", CV_8UC3, {}},
  };
  unsigned seed = 1;
  for (const Case& c : cases) {
    for (const cv::Size size : {cv::Size(37, 23), cv::Size(640, 480)}) {
      SCOPED_TRACE(std::string(c.ext) + " type " + std::to_string(c.type) + " " +
                   std::to_string(size.width) + "x" + std::to_string(size.height));
      cv::Mat image = Picture(size.height, size.width, c.type, seed++);
      if (c.params.size() == 2 && c.params[0] == cv::IMWRITE_PNG_BILEVEL) {
        cv::threshold(image, image, 127, 255, cv::THRESH_BINARY);
      }
      std::vector<uchar> encoded;
      ASSERT_TRUE(cv::imencode(c.ext, image, encoded, c.params));
      const cv::Mat theirs = cv::imdecode(encoded, cv::IMREAD_UNCHANGED);
      const cv::Mat ours = codecs::Decode(Bytes(encoded), "test");
      EXPECT_TRUE(Same(ours, theirs)) << ours.type() << " against " << theirs.type();
    }
  }
}

TEST(ImageCodecs, TiledTiffsDecodeAsOpenCvDecodesThem) {
  // OpenCV writes strips only; libtiff writes these tiles of 16 x 16 (partial at the
  // right and bottom edges).
  ::dome::testing::TempDir dir;
  for (const int type : {CV_8UC3, CV_16UC1}) {
    SCOPED_TRACE(type);
    const cv::Mat image = Picture(23, 37, type, 11);
    const auto path = dir.path() / "tiled.tif";
    const cv::Mat rgb = image.channels() == 3 ? image.clone() : image;
    if (image.channels() == 3) cv::cvtColor(image, rgb, cv::COLOR_BGR2RGB);
    ::dome::testing::WriteRawTiff(path, image.cols, image.rows, image.channels(),
                                  int(image.elemSize1()) * 8, SAMPLEFORMAT_UINT, rgb.data,
                                  /*tiled=*/true);
    const cv::Mat ours = ReadImage(path, ImageMode::kUnchanged);
    EXPECT_TRUE(Same(ours, image));
    EXPECT_TRUE(Same(ours, cv::imread(path.string(), cv::IMREAD_UNCHANGED)));
  }
}

TEST(ImageCodecs, PngBytesAreOpenCvsForBothEncodings) {
  unsigned seed = 7;
  for (const int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1, CV_16UC3}) {
    const cv::Mat image = Picture(120, 161, type, seed++);
    std::vector<uchar> fast, small;
    ASSERT_TRUE(cv::imencode(".png", image, fast));
    ASSERT_TRUE(cv::imencode(".png", image, small, {cv::IMWRITE_PNG_COMPRESSION, 3}));
    EXPECT_EQ(EncodePng(image, PngEncoding::kFast), Bytes(fast)) << type;
    EXPECT_EQ(EncodePng(image, PngEncoding::kSmall), Bytes(small)) << type;
    EXPECT_TRUE(Same(codecs::Decode(EncodePng(image), "png"), image));
  }
}

TEST(ImageCodecs, BadFilesNameTheProblem) {
  const cv::Mat image = Picture(64, 64, CV_8UC3, 3);
  std::vector<uchar> png, tif, bmp;
  ASSERT_TRUE(cv::imencode(".png", image, png));
  ASSERT_TRUE(cv::imencode(".tif", image, tif, {cv::IMWRITE_TIFF_COMPRESSION, 1}));
  ASSERT_TRUE(cv::imencode(".bmp", image, bmp));
  const auto cut = [](const std::vector<uchar>& v, size_t n) {
    return std::string(v.begin(), v.begin() + std::ptrdiff_t(n));
  };
  ExpectInputError([&] { codecs::Decode(cut(png, png.size() / 2), "half.png"); },
                   {"half.png", "PNG", "truncated"});
  ExpectInputError([&] { codecs::Decode(cut(png, png.size() - 12), "no_end.png"); },
                   {"no_end.png", "PNG"});
  ExpectInputError([&] { codecs::Decode(cut(tif, tif.size() / 2), "half.tif"); },
                   {"half.tif", "TIFF"});
  ExpectInputError([&] { codecs::Decode(cut(bmp, bmp.size() / 2), "half.bmp"); },
                   {"half.bmp", "BMP pixel data truncated"});
  ExpectInputError([&] { codecs::Decode("P5\n4 4\n255\n0000000000000000", "x.pgm"); },
                   {"x.pgm", "expected PNG, JPEG, TIFF or BMP"});
  ExpectInputError([&] { codecs::Decode("", "empty.png"); }, {"empty.png", "is empty"});
  // A JPEG cut after its header: libjpeg says what is wrong.
  ExpectInputError([&] { codecs::Decode("\xff\xd8\xff\xe0", "stub.jpg"); }, {"stub.jpg", "JPEG"});
  // RLE-compressed BMP: the header says so; we name it.
  std::string rle = Bytes(bmp);
  rle[30] = 1;
  ExpectInputError([&] { codecs::Decode(rle, "rle.bmp"); }, {"rle.bmp", "compressed BMP"});
  // A PNG claiming 2^20 x 2^20 pixels is refused before anything is allocated.
  std::string huge = Bytes(png);
  huge[16] = 0, huge[17] = 0x10, huge[18] = 0, huge[19] = 0;
  huge[20] = 0, huge[21] = 0x10, huge[22] = 0, huge[23] = 0;
  const uLong crc = crc32(0, reinterpret_cast<const Bytef*>(huge.data() + 12), 17);
  for (int i = 0; i < 4; ++i) huge[29 + i] = char(crc >> (24 - 8 * i));
  ExpectInputError([&] { codecs::Decode(huge, "huge.png"); },
                   {"huge.png", "implausible image size 1048576x1048576"});
}

}  // namespace
}  // namespace dome::io
