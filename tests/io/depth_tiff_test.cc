#include "io/depth_tiff.h"

#include <gtest/gtest.h>
#include <tiffio.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>

#include "io/file_util.h"
#include "io/image_io.h"
#include "test_util.h"

namespace dome::io {
namespace {

using ::dome::testing::ExpectInputError;
using ::dome::testing::TempDir;
using ::dome::testing::WriteRawTiff;

// A depth map with a hole pattern: values in [750, 5000) mm, every 7th pixel invalid.
cv::Mat SampleDepth(int rows = 61, int cols = 83) {
  cv::Mat depth(rows, cols, CV_32FC1);
  cv::RNG rng(7);
  for (int y = 0; y < rows; ++y) {
    for (int x = 0; x < cols; ++x) {
      depth.at<float>(y, x) = (y * cols + x) % 7 == 0 ? 0.0f : rng.uniform(750.0f, 5000.0f);
    }
  }
  return depth;
}

TEST(DepthTiff, RoundTripIsBitExact) {
  TempDir dir;
  const cv::Mat depth = SampleDepth();
  const auto path = dir / "depth.tif";
  WriteDepthTiff(path, depth);
  const cv::Mat back = ReadDepthTiff(path);
  ASSERT_EQ(back.type(), CV_32FC1);
  ASSERT_EQ(back.size(), depth.size());
  EXPECT_EQ(std::memcmp(back.data, depth.data, depth.total() * 4), 0);
}

TEST(DepthTiff, TagsSayOneChannelIeeeFloat) {
  TempDir dir;
  const auto path = dir / "depth.tiff";
  WriteDepthTiff(path, SampleDepth());
  TIFF* t = TIFFOpen(path.c_str(), "r");
  ASSERT_NE(t, nullptr);
  uint16_t spp = 0, bps = 0, format = 0;
  TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLESPERPIXEL, &spp);
  TIFFGetFieldDefaulted(t, TIFFTAG_BITSPERSAMPLE, &bps);
  TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLEFORMAT, &format);
  TIFFClose(t);
  EXPECT_EQ(spp, 1);
  EXPECT_EQ(bps, 32);
  EXPECT_EQ(format, SAMPLEFORMAT_IEEEFP);
}

TEST(DepthTiff, InteroperatesWithOpenCv) {
  TempDir dir;
  const cv::Mat depth = SampleDepth();
  const auto ours = dir / "ours.tif";
  WriteDepthTiff(ours, depth);
  const cv::Mat by_opencv = cv::imread(ours.string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(by_opencv.type(), CV_32FC1);
  EXPECT_EQ(cv::norm(by_opencv, depth, cv::NORM_INF), 0.0);

  const auto theirs = dir / "theirs.tif";
  ASSERT_TRUE(cv::imwrite(theirs.string(), depth));
  const cv::Mat back = ReadDepthTiff(theirs);
  EXPECT_EQ(cv::norm(back, depth, cv::NORM_INF), 0.0);
}

// Both encodings of a depth map: the compression each promises, the same values bit for
// bit through ours and OpenCV's readers, the description kept; a smooth map (a truth
// depth's kind) is smaller with kSmall's predictor.
TEST(DepthTiff, BothEncodingsRoundTripAndTheSmallOneKeepsASmoothMapSmall) {
  TempDir dir;
  cv::Mat smooth(90, 120, CV_32FC1);
  for (int y = 0; y < smooth.rows; ++y)
    for (int x = 0; x < smooth.cols; ++x) smooth.at<float>(y, x) = 2000.0f + 3.1f * x + 1.7f * y;
  for (const cv::Mat& depth : {SampleDepth(), smooth}) {
    size_t bytes[2] = {0, 0};
    for (const auto encoding : {DepthTiffEncoding::kSmall, DepthTiffEncoding::kFast}) {
      const bool fast = encoding == DepthTiffEncoding::kFast;
      const auto path = dir / (fast ? "fast.tif" : "small.tif");
      WriteDepthTiff(path, depth, encoding);
      EXPECT_EQ(ReadFileBytes(path), EncodeDepthTiff(depth, "map", encoding));
      bytes[fast] = ReadFileBytes(path).size();
      TIFF* t = TIFFOpen(path.c_str(), "r");
      ASSERT_NE(t, nullptr);
      uint16_t compression = 0;
      char* description = nullptr;
      TIFFGetFieldDefaulted(t, TIFFTAG_COMPRESSION, &compression);
      ASSERT_EQ(TIFFGetField(t, TIFFTAG_IMAGEDESCRIPTION, &description), 1);
      EXPECT_EQ(std::string(description),
                "dome depth map: z along the optical axis in mm, 0 = invalid");
      TIFFClose(t);
      EXPECT_EQ(compression, fast ? COMPRESSION_PACKBITS : COMPRESSION_ADOBE_DEFLATE);
      EXPECT_EQ(cv::norm(ReadDepthTiff(path), depth, cv::NORM_INF), 0.0);
      const cv::Mat by_opencv = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
      ASSERT_EQ(by_opencv.type(), CV_32FC1);
      EXPECT_EQ(cv::norm(by_opencv, depth, cv::NORM_INF), 0.0);
    }
    if (depth.data == smooth.data) {
      EXPECT_LT(2 * bytes[0], bytes[1]);
    }
  }
}

// The run-length float TIFF (reliability maps): PackBits, the same values bit for bit
// through OpenCV, a mostly-zero map in a fraction of its raw size; an empty or
// non-float image is refused naming where.
TEST(RunLengthFloatTiff, PackBitsRoundTripThroughOpenCv) {
  TempDir dir;
  cv::Mat m(120, 200, CV_32FC1, cv::Scalar(0));
  cv::RNG rng(5);
  rng.fill(m(cv::Rect(50, 40, 60, 30)), cv::RNG::UNIFORM, 0.0, 40.0);
  const std::string bytes = EncodeRunLengthFloatTiff(m, "test map", "map");
  EXPECT_LT(bytes.size(), size_t(60 * 30 * 4 + 120 * 200 * 4 / 40));
  const auto path = dir / "map.tiff";
  WriteFileAtomically(path, bytes);
  TIFF* t = TIFFOpen(path.c_str(), "r");
  ASSERT_NE(t, nullptr);
  uint16_t compression = 0, format = 0;
  TIFFGetFieldDefaulted(t, TIFFTAG_COMPRESSION, &compression);
  TIFFGetFieldDefaulted(t, TIFFTAG_SAMPLEFORMAT, &format);
  TIFFClose(t);
  EXPECT_EQ(compression, COMPRESSION_PACKBITS);
  EXPECT_EQ(format, SAMPLEFORMAT_IEEEFP);
  const cv::Mat back = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(back.type(), CV_32FC1);
  EXPECT_EQ(cv::norm(back, m, cv::NORM_INF), 0.0);
  ExpectInputError([] { EncodeRunLengthFloatTiff(cv::Mat(), "d", "reliability map of c1"); },
                   {"reliability map of c1", "a float TIFF needs a non-empty 1-channel float image"});
  ExpectInputError(
      [] { EncodeRunLengthFloatTiff(cv::Mat(4, 4, CV_8UC1), "d", "reliability map of c1"); },
      {"reliability map of c1", "1-channel float"});
}

TEST(DepthTiff, ReadsTiledFiles) {
  TempDir dir;
  const cv::Mat depth = SampleDepth(40, 37);
  const auto path = dir / "tiled.tif";
  WriteRawTiff(path, depth.cols, depth.rows, 1, 32, SAMPLEFORMAT_IEEEFP, depth.data, true);
  EXPECT_EQ(cv::norm(ReadDepthTiff(path), depth, cv::NORM_INF), 0.0);
}

TEST(DepthTiff, RejectsWrongSampleLayout) {
  TempDir dir;
  const std::vector<uint8_t> bytes8(10 * 10, 5);
  const auto gray8 = dir / "gray8.tif";
  WriteRawTiff(gray8, 10, 10, 1, 8, SAMPLEFORMAT_UINT, bytes8.data());
  ExpectInputError([&] { ReadDepthTiff(gray8); },
                   {gray8.string(), "1-channel 8-bit unsigned integer", "32-bit float"});
  const std::vector<float> rgb(10 * 10 * 3, 1.0f);
  const auto rgbf = dir / "rgb.tif";
  WriteRawTiff(rgbf, 10, 10, 3, 32, SAMPLEFORMAT_IEEEFP, rgb.data());
  ExpectInputError([&] { ReadDepthTiff(rgbf); }, {rgbf.string(), "3-channel 32-bit float"});
  const std::vector<int32_t> ints(10 * 10, 1);
  const auto int32 = dir / "int32.tif";
  WriteRawTiff(int32, 10, 10, 1, 32, SAMPLEFORMAT_INT, ints.data());
  ExpectInputError([&] { ReadDepthTiff(int32); }, {int32.string(), "signed integer"});
}

TEST(DepthTiff, RejectsNanAndNegativeValuesNamingThePixel) {
  TempDir dir;
  cv::Mat depth = SampleDepth(10, 12);
  depth.at<float>(4, 9) = std::numeric_limits<float>::quiet_NaN();
  const auto nan_file = dir / "nan.tif";
  WriteRawTiff(nan_file, depth.cols, depth.rows, 1, 32, SAMPLEFORMAT_IEEEFP, depth.data);
  ExpectInputError([&] { ReadDepthTiff(nan_file); }, {nan_file.string(), "(9, 4)", "nan"});
  depth.at<float>(4, 9) = -3.0f;
  const auto negative = dir / "negative.tif";
  WriteRawTiff(negative, depth.cols, depth.rows, 1, 32, SAMPLEFORMAT_IEEEFP, depth.data);
  ExpectInputError([&] { ReadDepthTiff(negative); }, {negative.string(), "(9, 4)", "-3"});
  // The writer refuses them too, naming the destination.
  ExpectInputError([&] { WriteDepthTiff(dir / "out.tif", depth); }, {"out.tif", "(9, 4)"});
  EXPECT_FALSE(std::filesystem::exists(dir / "out.tif"));
}

TEST(DepthTiff, MissingTruncatedAndGarbageFiles) {
  TempDir dir;
  ExpectInputError([&] { ReadDepthTiff(dir / "absent.tif"); }, {"absent.tif", "no such file"});
  const auto garbage = dir / "garbage.tif";
  std::ofstream(garbage) << "definitely not a tiff";
  ExpectInputError([&] { ReadDepthTiff(garbage); }, {garbage.string(), "not a readable TIFF"});

  // libtiff writes the directory after the pixel data: half a file has no directory.
  const cv::Mat depth = SampleDepth(64, 64);
  const auto full = dir / "full.tif";
  WriteDepthTiff(full, depth);
  std::string bytes = ReadFileBytes(full);
  const auto truncated = dir / "truncated.tif";
  std::ofstream(truncated, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  ExpectInputError([&] { ReadDepthTiff(truncated); }, {truncated.string()});
  // Garbage inside the Deflate stream (the strips start right after the 8-byte header).
  for (size_t i = 20; i < 400; ++i) {
    bytes[i] = static_cast<char>(0xA5);
  }
  const auto corrupt = dir / "corrupt.tif";
  std::ofstream(corrupt, std::ios::binary) << bytes;
  ExpectInputError([&] { ReadDepthTiff(corrupt); }, {corrupt.string(), "corrupt TIFF data"});
}

TEST(DepthTiff, WriteIntoMissingFolderNamesIt) {
  TempDir dir;
  const auto path = dir / "missing/depth.tif";
  ExpectInputError([&] { WriteDepthTiff(path, SampleDepth()); }, {path.string(), "does not exist"});
}

TEST(DepthPng16, RoundsClampsAndKeepsValidity) {
  TempDir dir;
  cv::Mat depth(1, 6, CV_32FC1);
  const float values[] = {0.0f, 0.3f, 749.4f, 749.6f, 65535.2f, 70000.0f};
  for (int i = 0; i < 6; ++i) {
    depth.at<float>(0, i) = values[i];
  }
  const auto path = dir / "depth.png";
  WriteDepthPng16(path, depth);
  const cv::Mat raw = ReadImage(path, ImageMode::kUnchanged);
  ASSERT_EQ(raw.type(), CV_16UC1);
  const uint16_t expected[] = {0, 1, 749, 750, 65535, 65535};
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(raw.at<uint16_t>(0, i), expected[i]) << i;
  }
  const cv::Mat back = ReadDepthMap(path);
  ASSERT_EQ(back.type(), CV_32FC1);
  EXPECT_EQ(back.at<float>(0, 3), 750.0f);

  const auto color = dir / "color.png";
  WriteImage(color, cv::Mat(3, 3, CV_8UC3, cv::Scalar(1, 2, 3)));
  ExpectInputError([&] { ReadDepthPng16(color); }, {color.string(), "16-bit"});
  ExpectInputError([&] { ReadDepthMap(dir / "depth.exr"); }, {"depth.exr", "extension"});
}

TEST(DepthPreview, ThePngIsAPaletteOfThePicturesColours) {
  cv::Mat depth = SampleDepth(120, 160);
  depth(cv::Rect(0, 0, 30, 120)).setTo(0.0f);  // no depth: black
  const cv::Mat picture = DepthPreview(depth);
  std::vector<cv::Vec3b> palette;
  const cv::Mat indices = DepthPreviewIndices(depth, {}, &palette);
  ASSERT_EQ(palette.size(), size_t(1 + kDepthPreviewLevels));
  EXPECT_EQ(palette[0], cv::Vec3b(0, 0, 0));
  EXPECT_EQ(indices.at<uint8_t>(50, 10), 0);
  const std::string png = EncodeDepthPreviewPng(depth, "sample");
  EXPECT_EQ(ReadPngHeader(png, "sample").colour_type, 3);
  const cv::Mat decoded = DecodeImage(png, ImageMode::kUnchanged, "sample");
  ASSERT_EQ(decoded.type(), CV_8UC3);
  EXPECT_EQ(cv::norm(decoded, picture, cv::NORM_INF), 0.0);
  // The colours span the map: the nearest 1 % are the colour map's near end, the farthest
  // its far end, and many levels lie between.
  double lo = 0, hi = 0;
  cv::minMaxLoc(indices, &lo, &hi, nullptr, nullptr, depth > 0);
  EXPECT_EQ(lo, 1.0);
  EXPECT_EQ(hi, double(kDepthPreviewLevels));
  // Fewer than half the bytes of the same picture as BGR.
  EXPECT_LT(png.size(), EncodePng(picture, PngEncoding::kFast).size() / 2);
}

TEST(DepthPreview, NearIsTheHighEndAndInvalidIsBlack) {
  cv::Mat depth(1, 4, CV_32FC1);
  depth.at<float>(0, 0) = 1000.0f;  // near
  depth.at<float>(0, 1) = 3000.0f;  // far
  depth.at<float>(0, 2) = 0.0f;     // invalid
  depth.at<float>(0, 3) = 2000.0f;
  DepthPreviewOptions options;
  options.near_mm = 1000.0;
  options.far_mm = 3000.0;
  const cv::Mat preview = DepthPreview(depth, options);
  ASSERT_EQ(preview.type(), CV_8UC3);
  cv::Mat ends(1, 2, CV_8UC1);
  ends.at<uint8_t>(0, 0) = 255;
  ends.at<uint8_t>(0, 1) = 0;
  cv::Mat ends_bgr;
  cv::applyColorMap(ends, ends_bgr, cv::COLORMAP_TURBO);
  EXPECT_EQ(preview.at<cv::Vec3b>(0, 0), ends_bgr.at<cv::Vec3b>(0, 0));
  EXPECT_EQ(preview.at<cv::Vec3b>(0, 1), ends_bgr.at<cv::Vec3b>(0, 1));
  EXPECT_EQ(preview.at<cv::Vec3b>(0, 2), cv::Vec3b(0, 0, 0));

  TempDir dir;
  WriteDepthPreviewPng(dir / "preview.png", SampleDepth());
  EXPECT_EQ(ReadImage(dir / "preview.png", ImageMode::kUnchanged).type(), CV_8UC3);
  ExpectInputError([&] { WriteDepthPreviewPng(dir / "preview.jpg", SampleDepth()); },
                   {"preview.jpg", ".png"});

  options.far_mm = 500.0;
  ExpectInputError([&] { options.Check(); }, {"near_mm/far_mm"});
}

}  // namespace
}  // namespace dome::io
