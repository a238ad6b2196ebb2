#include "io/image_io.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/error.h"
#include "io/file_util.h"
#include "test_util.h"

namespace dome::io {
namespace {

using ::dome::testing::ExpectInputError;
using ::dome::testing::TempDir;

const std::filesystem::path kRobovisionImage =
    std::filesystem::path(DOME_SHARED_DIR) /
    "data/robovision/2016_10_24__17_43_02/image_camera01.png";

void WriteBytes(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

TEST(ReadImage, RobovisionRgbaInEveryMode) {
  if (!std::filesystem::exists(kRobovisionImage)) {
    GTEST_SKIP() << "no shared data";
  }
  const cv::Mat gray = ReadImage(kRobovisionImage, ImageMode::kGray8);
  const cv::Mat bgr = ReadImage(kRobovisionImage, ImageMode::kBgr8);
  const cv::Mat bgra = ReadImage(kRobovisionImage, ImageMode::kBgra8);
  const cv::Mat raw = ReadImage(kRobovisionImage, ImageMode::kUnchanged);
  EXPECT_EQ(gray.type(), CV_8UC1);
  EXPECT_EQ(bgr.type(), CV_8UC3);
  EXPECT_EQ(bgra.type(), CV_8UC4);
  EXPECT_EQ(raw.type(), CV_8UC4);
  EXPECT_EQ(gray.size(), cv::Size(1280, 1024));
  // R = G = B in these frames, so gray is exactly the first channel.
  cv::Mat b;
  cv::extractChannel(bgra, b, 0);
  EXPECT_EQ(cv::norm(gray, b, cv::NORM_INF), 0.0);
  // Alpha is 255 or 0 (undistortion border).
  cv::Mat alpha;
  cv::extractChannel(bgra, alpha, 3);
  EXPECT_EQ(cv::countNonZero(alpha == 255) + cv::countNonZero(alpha == 0), alpha.total());
  // Decoded as BGR, the alpha is dropped, not composited: the colour channels of the
  // unchanged decode (the stage's frame memo serves BGR requests from them).
  cv::Mat dropped;
  cv::cvtColor(raw, dropped, cv::COLOR_BGRA2BGR);
  EXPECT_EQ(cv::norm(dropped, bgr, cv::NORM_INF), 0.0);
}

// The same for a BGRA PNG with colour under transparent pixels.
TEST(DecodeImage, BgrOfABgraPngIsItsColourChannels) {
  cv::Mat bgra(40, 60, CV_8UC4);
  cv::RNG(9).fill(bgra, cv::RNG::UNIFORM, 0, 256);
  std::vector<uchar> png;
  ASSERT_TRUE(cv::imencode(".png", bgra, png));
  const std::string bytes(png.begin(), png.end());
  const cv::Mat raw = DecodeImage(bytes, ImageMode::kUnchanged, "bgra.png");
  ASSERT_EQ(raw.type(), CV_8UC4);
  EXPECT_EQ(cv::norm(raw, bgra, cv::NORM_INF), 0.0);
  cv::Mat dropped;
  cv::cvtColor(raw, dropped, cv::COLOR_BGRA2BGR);
  EXPECT_EQ(cv::norm(dropped, DecodeImage(bytes, ImageMode::kBgr8, "bgra.png"), cv::NORM_INF), 0.0);
}

TEST(PalettePng, DecodesToThePaletteColoursOfItsIndices) {
  std::vector<cv::Vec3b> palette;
  for (int i = 0; i < 256; ++i) palette.emplace_back(uint8_t(i), uint8_t(255 - i), uint8_t(7 * i));
  cv::Mat indices(37, 53, CV_8UC1);
  cv::RNG(5).fill(indices, cv::RNG::UNIFORM, 0, 256);
  for (PngEncoding encoding : {PngEncoding::kSmall, PngEncoding::kFast}) {
    const std::string bytes = EncodePalettePng(indices, palette, encoding);
    const PngHeader h = ReadPngHeader(bytes, "palette.png");
    EXPECT_EQ(h.colour_type, 3);
    EXPECT_EQ(h.bit_depth, 8);
    EXPECT_EQ(h.width, 53);
    EXPECT_EQ(h.height, 37);
    const cv::Mat bgr = DecodeImage(bytes, ImageMode::kUnchanged, "palette.png");
    ASSERT_EQ(bgr.type(), CV_8UC3);
    ASSERT_EQ(bgr.size(), indices.size());
    for (int y = 0; y < indices.rows; ++y) {
      for (int x = 0; x < indices.cols; ++x) {
        ASSERT_EQ(bgr.at<cv::Vec3b>(y, x), palette[indices.at<uint8_t>(y, x)]) << x << "," << y;
      }
    }
  }
  // Fewer colours than 256: indices below the palette's size.
  const std::vector<cv::Vec3b> two = {cv::Vec3b(0, 0, 0), cv::Vec3b(10, 20, 30)};
  const cv::Mat checker = (cv::Mat_<uint8_t>(2, 2) << 0, 1, 1, 0);
  const cv::Mat back = DecodeImage(EncodePalettePng(checker, two), ImageMode::kUnchanged, "two");
  EXPECT_EQ(back.at<cv::Vec3b>(0, 1), cv::Vec3b(10, 20, 30));
  EXPECT_EQ(back.at<cv::Vec3b>(1, 1), cv::Vec3b(0, 0, 0));
}

TEST(PngHeader, SaysSizeAndTypeWithoutDecoding) {
  const std::string colour = EncodePng(cv::Mat(7, 13, CV_8UC3, cv::Scalar(1, 2, 3)));
  const PngHeader c = ReadPngHeader(colour, "preview");
  EXPECT_EQ(c.width, 13);
  EXPECT_EQ(c.height, 7);
  EXPECT_EQ(c.bit_depth, 8);
  EXPECT_EQ(c.colour_type, 2);
  const PngHeader g = ReadPngHeader(EncodePng(cv::Mat(4, 5, CV_16UC1, cv::Scalar(9))), "depth");
  EXPECT_EQ(g.bit_depth, 16);
  EXPECT_EQ(g.colour_type, 0);
  ExpectInputError([&] { ReadPngHeader("GIF89a, not a PNG at all, no", "w1 preview"); },
                   {"w1 preview", "no PNG signature"});
  ExpectInputError([&] { ReadPngHeader(colour.substr(0, 20), "w1 preview"); },
                   {"w1 preview", "not a PNG"});
  std::string odd = colour;
  odd[12] = 'X';  // the first chunk is not IHDR
  ExpectInputError([&] { ReadPngHeader(odd, "w1 preview"); }, {"w1 preview", "no IHDR"});
}

// Both encodings are lossless for every type PNG holds; on a mask (a disc on black)
// the fast one (Sub filter, zlib level 1, run-length matches) costs few bytes more.
TEST(EncodePng, BothEncodingsRoundTripAndTheFastOneKeepsAMaskSmall) {
  for (const int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1, CV_16UC3}) {
    cv::Mat image(37, 53, type);
    cv::RNG(int64_t(type) + 5).fill(image, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH(type) == CV_8U ? 256 : 65536);
    for (const std::string& bytes : {EncodePng(image), EncodePng(image, PngEncoding::kFast)}) {
      const cv::Mat back = DecodeImage(bytes, ImageMode::kUnchanged, "round trip");
      ASSERT_EQ(back.type(), type);
      EXPECT_EQ(cv::norm(back, image, cv::NORM_INF), 0.0) << "type " << type;
    }
  }
  cv::Mat mask(245, 320, CV_8UC1, cv::Scalar(0));
  cv::circle(mask, cv::Point(160, 120), 60, cv::Scalar(255), cv::FILLED);
  const std::string fast = EncodePng(mask, PngEncoding::kFast), small = EncodePng(mask);
  EXPECT_LE(double(fast.size()), 1.1 * double(small.size()));
  EXPECT_EQ(cv::norm(DecodeImage(fast, ImageMode::kUnchanged, "fast"), mask, cv::NORM_INF), 0.0);
}

TEST(ReadImage, MissingFileNamesIt) {
  TempDir dir;
  const auto path = dir / "absent.png";
  ExpectInputError([&] { ReadImage(path, ImageMode::kGray8); }, {path.string(), "no such file"});
  ExpectInputError([&] { ReadImage(dir.path(), ImageMode::kGray8); }, {"is a folder"});
}

TEST(ReadImage, UnreadableFileNamesIt) {
  if (::dome::testing::RunningAsRoot()) {
    GTEST_SKIP() << "root reads anything";
  }
  TempDir dir;
  const auto path = dir / "locked.png";
  WriteImage(path, cv::Mat(4, 4, CV_8UC1, cv::Scalar(7)));
  std::filesystem::permissions(path, std::filesystem::perms::none);
  ExpectInputError([&] { ReadImage(path, ImageMode::kGray8); },
                   {path.string(), "cannot open for reading"});
}

TEST(ReadImage, CorruptAndTruncatedFilesNameThem) {
  TempDir dir;
  const auto garbage = dir / "garbage.png";
  WriteBytes(garbage, "this is not an image at all, just text");
  ExpectInputError([&] { ReadImage(garbage, ImageMode::kBgr8); },
                   {garbage.string(), "not a decodable image"});

  const auto empty = dir / "empty.png";
  WriteBytes(empty, "");
  ExpectInputError([&] { ReadImage(empty, ImageMode::kBgr8); }, {empty.string(), "empty"});

  cv::Mat noise(64, 64, CV_8UC3);
  cv::randu(noise, 0, 255);
  const std::string png = EncodePng(noise);
  const auto truncated = dir / "truncated.png";
  WriteBytes(truncated, png.substr(0, png.size() / 2));
  ExpectInputError([&] { ReadImage(truncated, ImageMode::kBgr8); },
                   {truncated.string(), "not a decodable image"});
}

TEST(ReadImage, WrongDepthOrChannelsForTheMode) {
  TempDir dir;
  const auto deep = dir / "deep.png";
  WriteImage(deep, cv::Mat(8, 8, CV_16UC1, cv::Scalar(1000)));
  ExpectInputError([&] { ReadImage(deep, ImageMode::kGray8); }, {deep.string(), "16-bit", "8-bit"});
  EXPECT_EQ(ReadImage(deep, ImageMode::kUnchanged).type(), CV_16UC1);

  const auto rgb = dir / "rgb.png";
  WriteImage(rgb, cv::Mat(8, 8, CV_8UC3, cv::Scalar(1, 2, 3)));
  ExpectInputError([&] { ReadImage(rgb, ImageMode::kBgra8); }, {rgb.string(), "alpha"});
  const cv::Mat gray = ReadImage(rgb, ImageMode::kGray8);
  EXPECT_EQ(gray.type(), CV_8UC1);

  const auto gray_file = dir / "gray.png";
  WriteImage(gray_file, cv::Mat(8, 8, CV_8UC1, cv::Scalar(9)));
  const cv::Mat bgr = ReadImage(gray_file, ImageMode::kBgr8);
  ASSERT_EQ(bgr.type(), CV_8UC3);
  EXPECT_EQ(bgr.at<cv::Vec3b>(3, 3), cv::Vec3b(9, 9, 9));
}

TEST(WriteImage, RoundTripsExactly) {
  TempDir dir;
  for (const int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1}) {
    cv::Mat image(37, 53, type);
    cv::randu(image, 0, type == CV_16UC1 ? 65535 : 255);
    const auto path = dir / ("image_" + std::to_string(type) + ".png");
    WriteImage(path, image);
    const cv::Mat back = ReadImage(path, ImageMode::kUnchanged);
    ASSERT_EQ(back.type(), type);
    EXPECT_EQ(cv::norm(image, back, cv::NORM_INF), 0.0);
  }
  // No temporary files left behind.
  int files = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    ++files;
  }
  EXPECT_EQ(files, 4);
}

TEST(WriteImage, BadDestinationsNameTheFile) {
  TempDir dir;
  const cv::Mat image(4, 4, CV_8UC1, cv::Scalar(1));
  const auto missing = dir / "no/such/folder/out.png";
  ExpectInputError([&] { WriteImage(missing, image); }, {missing.string(), "does not exist"});
  std::ofstream(dir / "plain_file") << "x";
  ExpectInputError([&] { WriteImage(dir / "plain_file/out.png", image); },
                   {"plain_file/out.png", "is not a folder"});
  const auto jpeg = dir / "out.jpg";
  ExpectInputError([&] { WriteImage(jpeg, image); }, {jpeg.string(), ".png"});
  if (!::dome::testing::RunningAsRoot()) {
    const auto locked = dir / "locked";
    std::filesystem::create_directory(locked);
    std::filesystem::permissions(
        locked, std::filesystem::perms::owner_read | std::filesystem::perms::owner_exec);
    ExpectInputError([&] { WriteImage(locked / "out.png", image); },
                     {(locked / "out.png").string(), "cannot write"});
    std::filesystem::permissions(locked, std::filesystem::perms::owner_all);
  }
}

}  // namespace
}  // namespace dome::io
