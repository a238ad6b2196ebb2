#include "view/derived.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <opencv2/imgcodecs.hpp>

#include "io/file_util.h"
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

}  // namespace
}  // namespace dome::view
