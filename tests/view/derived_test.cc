#include "view/derived.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "io/file_util.h"
#include "io/image_io.h"
#include "silhouette/take_masks.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"
#include "view_fixture.h"

namespace dome::view {
namespace {

std::vector<float> Decode(const std::string& bytes) {
  std::vector<float> v(bytes.size() / 4);
  std::memcpy(v.data(), bytes.data(), v.size() * 4);
  return v;
}

TEST(VertexDistances, ExactDistancesToAReferenceSurface) {
  const io::Mesh reference = testing::Square(1000, 0);
  io::Mesh m;
  // Above the face, below it, on it, and beyond an edge (closest point on the edge).
  m.vertices = {{0, 0, 5}, {300, -200, -3}, {10, 20, 0}, {1003, 0, 4}};
  const std::vector<float> d = VertexDistances(m, reference, 2);
  ASSERT_EQ(d.size(), 4u);
  EXPECT_NEAR(d[0], 5.0, 1e-4);
  EXPECT_NEAR(d[1], 3.0, 1e-4);
  EXPECT_NEAR(d[2], 0.0, 1e-4);
  EXPECT_NEAR(d[3], 5.0, 1e-4);
  const std::vector<float> none = VertexDistances(m, io::Mesh{});
  EXPECT_TRUE(std::isinf(none[0]));
}

TEST(VertexDistances, Float32FileRoundTrips) {
  const std::vector<float> v = {0.0f, 1.5f, -2.25f, 1e30f};
  const std::string bytes = EncodeFloat32Le(v);
  ASSERT_EQ(bytes.size(), 16u);
  EXPECT_EQ(Decode(bytes), v);
}

TEST(DerivedFiles, ErrorFileHoldsEachVertexDistanceToTruth) {
  dome::testing::TempDir tmp;
  const auto f = testing::MakeViewFixture(tmp.path());
  const ViewerIndex index = BuildIndex(f.out, f.take);
  // The fused square lies 7 mm above the truth square, the decimated one 3 mm below.
  for (const float d : Decode(VertexErrorFile(index, 0, MeshVariant::kFused)))
    EXPECT_NEAR(d, 7.0, 1e-4);
  const auto dec = Decode(VertexErrorFile(index, 0, MeshVariant::kDecimated));
  ASSERT_EQ(dec.size(), 4u);
  for (const float d : dec) EXPECT_NEAR(d, 3.0, 1e-4);
  dome::testing::ExpectInputError([&] { VertexErrorFile(index, 1, MeshVariant::kFused); },
                                  {"no truth mesh"});
  dome::testing::ExpectInputError([&] { VertexErrorFile(index, 1, MeshVariant::kDecimated); },
                                  {"no decimated mesh"});
}

TEST(DerivedFiles, CorruptMeshIsAnInputErrorNamingIt) {
  dome::testing::TempDir tmp;
  const auto f = testing::MakeViewFixture(tmp.path());
  io::WriteFileAtomically(f.out / f.instants[0] / "mesh.ply", "ply\nformat ascii 1.0\ngarbage\n");
  const ViewerIndex index = BuildIndex(f.out, f.take);
  dome::testing::ExpectInputError([&] { VertexErrorFile(index, 0, MeshVariant::kFused); },
                                  {"mesh.ply"});
}

TEST(DerivedFiles, DepthPreviewIsAColourMappedPng) {
  dome::testing::TempDir tmp;
  const auto f = testing::MakeViewFixture(tmp.path());
  const ViewerIndex index = BuildIndex(f.out, f.take);
  const std::string png = DepthPreviewFile(index, 0, 0);
  const cv::Mat img = cv::imdecode(std::vector<uchar>(png.begin(), png.end()), cv::IMREAD_COLOR);
  ASSERT_EQ(img.cols, 64);
  ASSERT_EQ(img.rows, 48);
  // No depth (the left 10 columns) is black; depth is coloured.
  EXPECT_EQ(img.at<cv::Vec3b>(20, 5), cv::Vec3b(0, 0, 0));
  const cv::Vec3b c = img.at<cv::Vec3b>(20, 40);
  EXPECT_GT(int(c[0]) + c[1] + c[2], 0);
  dome::testing::ExpectInputError([&] { DepthPreviewFile(index, 0, 1); }, {"c1", "no depth map"});
  io::WriteFileAtomically(f.take / "truth" / f.instants[0] / "depth" / "c0.tiff", "not a tiff");
  dome::testing::ExpectInputError([&] { DepthPreviewFile(index, 0, 0); }, {"c0.tiff"});
}

TEST(DerivedFiles, MaskPreviewIsTheImageWithItsMask) {
  dome::testing::TempDir tmp;
  const auto f = testing::MakeViewFixture(tmp.path());
  // c1 gets a background plate: its first frame, darker than half in a square that the
  // frame shows white; the mask must find the square exactly (the plate equals the
  // frame elsewhere).
  const take::Take take = take::OpenTake(f.take);
  const auto frame_path = take.FramePath(f.instants[0], "c1");
  cv::Mat frame = io::ReadImage(frame_path, io::ImageMode::kGray8);
  const cv::Rect square(20, 12, 16, 14);
  cv::Mat plate = frame.clone();
  plate(square) = plate(square) / 2;
  std::filesystem::create_directories(f.take / "background");
  io::WriteImage(f.take / "background" / "c1.png", plate);
  frame(square).setTo(255);
  io::WriteImage(frame_path, frame);
  const ViewerIndex index = BuildIndex(f.out, f.take);
  EXPECT_EQ(index.mask_sources, (std::vector<std::string>{"median", "plate", "median", "median"}));
  EXPECT_EQ(index.masks_unavailable, "");
  const std::string png = MaskPreviewFile(index, 0, 1);
  const cv::Mat img = cv::imdecode(std::vector<uchar>(png.begin(), png.end()), cv::IMREAD_COLOR);
  cv::Mat expected_mask = cv::Mat::zeros(48, 64, CV_8UC1);
  expected_mask(square).setTo(255);
  const cv::Mat expected = silhouette::MaskPreview(frame, expected_mask);
  ASSERT_EQ(img.size(), expected.size());
  cv::Mat diff;
  cv::absdiff(img, expected, diff);
  cv::cvtColor(diff, diff, cv::COLOR_BGR2GRAY);
  std::vector<cv::Point> where;
  cv::findNonZero(diff, where);
  EXPECT_EQ(where.size(), 0u) << "first at " << (where.empty() ? cv::Point() : where[0]);
  EXPECT_NE(IndexJson(index, false).find("\"mask\": \"derived/mask/" + f.instants[0] +
                                         "/c1.png\", \"mask_source\": \"plate\""),
            std::string::npos);
}

TEST(DerivedFiles, TakeWithoutMasksSaysWhy) {
  dome::testing::TempDir tmp;
  // Two instants, no plates or given masks: no median background is possible.
  const auto rig = take::testing::MakeRingRig(2, 64, 48);
  const auto take = take::testing::WriteTake(tmp / "take", rig, 2);
  std::filesystem::create_directories(tmp / "out");
  const ViewerIndex index = BuildIndex(tmp / "out", take);
  EXPECT_NE(index.masks_unavailable.find("at least 3"), std::string::npos)
      << index.masks_unavailable;
  ASSERT_EQ(index.instants.size(), 2u);
  EXPECT_FALSE(index.instants[0].cameras[0].mask);
  EXPECT_NE(IndexJson(index, false).find("\"mask\": null"), std::string::npos);
  dome::testing::ExpectInputError([&] { MaskPreviewFile(index, 0, 0); },
                                  {index.instants[0].name + "/c0", "no mask", "at least 3"});
}

}  // namespace
}  // namespace dome::view
