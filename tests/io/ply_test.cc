#include "io/ply.h"

#include <gtest/gtest.h>

#include <bit>
#include <cstring>
#include <fstream>

#include "io/file_util.h"
#include "test_util.h"

namespace dome::io {
namespace {

using ::dome::testing::ExpectInputError;
using ::dome::testing::TempDir;

const std::filesystem::path kRobovision =
    std::filesystem::path(DOME_SHARED_DIR) / "data/robovision";

Mesh SampleMesh(bool normals, bool colors, bool faces) {
  Mesh m;
  for (int i = 0; i < 50; ++i) {
    m.vertices.emplace_back(0.1f * i - 3.0f, 1.0f / (i + 1), 1234.5678f + i);
    if (normals) {
      m.normals.emplace_back(Eigen::Vector3f(i, 1, -2).normalized());
    }
    if (colors) {
      m.colors.emplace_back(i, 255 - i, 3 * i);
      m.alphas.push_back(static_cast<uint8_t>(200 + i));
    }
  }
  if (faces) {
    for (int i = 0; i + 2 < 50; ++i) {
      m.faces.emplace_back(i, i + 1, i + 2);
    }
  }
  return m;
}

void ExpectSameMesh(const Mesh& a, const Mesh& b) {
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  ASSERT_EQ(a.normals.size(), b.normals.size());
  ASSERT_EQ(a.colors.size(), b.colors.size());
  ASSERT_EQ(a.alphas.size(), b.alphas.size());
  ASSERT_EQ(a.faces.size(), b.faces.size());
  for (size_t i = 0; i < a.vertices.size(); ++i) {
    EXPECT_EQ(a.vertices[i], b.vertices[i]) << i;
    if (!a.normals.empty()) {
      EXPECT_EQ(a.normals[i], b.normals[i]) << i;
    }
    if (!a.colors.empty()) {
      EXPECT_EQ(a.colors[i], b.colors[i]) << i;
    }
    if (!a.alphas.empty()) {
      EXPECT_EQ(a.alphas[i], b.alphas[i]) << i;
    }
  }
  for (size_t i = 0; i < a.faces.size(); ++i) {
    EXPECT_EQ(a.faces[i], b.faces[i]) << i;
  }
}

// Appends `value` in the given byte order.
template <typename T>
void Put(std::string& out, T value, bool big_endian) {
  char b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));
  if (big_endian != (std::endian::native == std::endian::big)) {
    std::reverse(b, b + sizeof(T));
  }
  out.append(b, sizeof(T));
}

TEST(ReadPly, RobovisionReferences) {
  if (!std::filesystem::exists(kRobovision)) {
    GTEST_SKIP() << "no shared data";
  }
  const Mesh m = ReadPly(kRobovision / "2016_10_24__17_43_02/reference.ply");
  ASSERT_EQ(m.vertices.size(), 51543u);
  EXPECT_EQ(m.normals.size(), 51543u);
  EXPECT_EQ(m.colors.size(), 51543u);
  EXPECT_EQ(m.alphas.size(), 51543u);
  EXPECT_TRUE(m.faces.empty());
  EXPECT_EQ(m.vertices[0], Eigen::Vector3f(0.00682005f, 0.0280556f, 0.0102245f));
  EXPECT_EQ(m.normals[0], Eigen::Vector3f(0.457443f, 0.488056f, -0.743336f));
  EXPECT_EQ(m.colors[0], Color3u8(5, 5, 5));
  EXPECT_EQ(m.alphas[0], 255);
  EXPECT_EQ(m.vertices.back(), Eigen::Vector3f(0.0105911f, -0.0126942f, 0.0128299f));
  EXPECT_EQ(m.colors.back(), Color3u8(21, 21, 21));

  const std::pair<const char*, size_t> others[] = {{"2016_10_24__17_44_40", 40676},
                                                   {"2016_10_24__18_26_08", 30355},
                                                   {"2016_10_25__12_11_32", 18741}};
  for (const auto& [scene, count] : others) {
    EXPECT_EQ(ReadPly(kRobovision / scene / "reference.ply").vertices.size(), count) << scene;
  }
}

TEST(ReadPly, RobovisionRoundTripsThroughBinaryAndAscii) {
  if (!std::filesystem::exists(kRobovision)) {
    GTEST_SKIP() << "no shared data";
  }
  TempDir dir;
  const Mesh m = ReadPly(kRobovision / "2016_10_25__12_11_32/reference.ply");
  WritePly(dir / "bin.ply", m);
  ExpectSameMesh(m, ReadPly(dir / "bin.ply"));
  WritePly(dir / "ascii.ply", m, {PlyFormat::kAscii, {"units m"}});
  ExpectSameMesh(m, ReadPly(dir / "ascii.ply"));
}

TEST(WritePly, RoundTripsEveryAttributeCombination) {
  TempDir dir;
  for (const PlyFormat format : {PlyFormat::kBinaryLittleEndian, PlyFormat::kAscii}) {
    for (int mask = 0; mask < 8; ++mask) {
      const Mesh m = SampleMesh(mask & 1, mask & 2, mask & 4);
      const auto path = dir / ("m" + std::to_string(mask) + ".ply");
      WritePly(path, m, {format, {"units mm", "written by dome tests"}});
      ExpectSameMesh(m, ReadPly(path));
    }
  }
  const std::string header = EncodePly(SampleMesh(true, true, true)).substr(0, 400);
  EXPECT_NE(header.find("format binary_little_endian 1.0"), std::string::npos);
  EXPECT_NE(header.find("property list uchar int vertex_indices"), std::string::npos);
  EXPECT_EQ(EncodePly(SampleMesh(false, false, false)).find("element face"), std::string::npos);
}

TEST(ReadPly, BigEndianDoublesUnknownPropertiesAndElements) {
  // vertex: double x y z, plus properties and a list we must skip; face: uint count,
  // uint indices, extra list; an "edge" element and a trailing "material" element.
  std::string ply =
      "ply\r\nformat binary_big_endian 1.0\r\ncomment made by hand\r\n"
      "element vertex 4\r\nproperty double x\r\nproperty short flags\r\nproperty double y\r\n"
      "property double z\r\nproperty list uchar float junk\r\nproperty float nx\r\n"
      "property float ny\r\nproperty float nz\r\n"
      "element edge 2\r\nproperty list ushort int ends\r\nproperty char kind\r\n"
      "element face 2\r\nproperty list uint uint vertex_index\r\nproperty list uchar double tex\r\n"
      "property uchar flag\r\nelement material 1\r\nproperty double shininess\r\nend_header\r\n";
  const bool be = true;
  for (int i = 0; i < 4; ++i) {
    Put<double>(ply, i + 0.25, be);
    Put<int16_t>(ply, -7, be);
    Put<double>(ply, 10.0 * i, be);
    Put<double>(ply, -1e3 * i, be);
    Put<uint8_t>(ply, static_cast<uint8_t>(i), be);  // i junk floats
    for (int k = 0; k < i; ++k) {
      Put<float>(ply, 9.0f, be);
    }
    Put<float>(ply, 0.0f, be);
    Put<float>(ply, 0.0f, be);
    Put<float>(ply, 1.0f, be);
  }
  for (int e = 0; e < 2; ++e) {
    Put<uint16_t>(ply, 2, be);
    Put<int32_t>(ply, e, be);
    Put<int32_t>(ply, e + 1, be);
    Put<int8_t>(ply, -1, be);
  }
  // A triangle and a quad (split as a fan).
  Put<uint32_t>(ply, 3, be);
  for (uint32_t v : {0u, 1u, 2u}) {
    Put<uint32_t>(ply, v, be);
  }
  Put<uint8_t>(ply, 0, be);
  Put<uint8_t>(ply, 1, be);
  Put<uint32_t>(ply, 4, be);
  for (uint32_t v : {0u, 1u, 2u, 3u}) {
    Put<uint32_t>(ply, v, be);
  }
  Put<uint8_t>(ply, 2, be);
  Put<double>(ply, 0.5, be);
  Put<double>(ply, 0.5, be);
  Put<uint8_t>(ply, 1, be);
  Put<double>(ply, 30.0, be);

  const Mesh m = ParsePly(ply, "hand.ply");
  ASSERT_EQ(m.vertices.size(), 4u);
  EXPECT_EQ(m.vertices[3], Eigen::Vector3f(3.25f, 30.0f, -3000.0f));
  ASSERT_EQ(m.normals.size(), 4u);
  EXPECT_EQ(m.normals[2], Eigen::Vector3f(0, 0, 1));
  EXPECT_TRUE(m.colors.empty());
  ASSERT_EQ(m.faces.size(), 3u);
  EXPECT_EQ(m.faces[0], Eigen::Vector3i(0, 1, 2));
  EXPECT_EQ(m.faces[1], Eigen::Vector3i(0, 1, 2));
  EXPECT_EQ(m.faces[2], Eigen::Vector3i(0, 2, 3));
}

TEST(ReadPly, AsciiPolygonsColorsAsFloatsAndBlankLines) {
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
      "property float z\nproperty float red\nproperty float green\nproperty float blue\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0 1 0 0.5\n1 0 0 1 1 1\n\n1 1 0 0 0 0\n0 1 0 0 0 0\n+0.5 1.5 0 0 0 0\n"
      "5 0 1 2 3 4\n";
  const Mesh m = ParsePly(ply, "pentagon.ply");
  ASSERT_EQ(m.vertices.size(), 5u);
  EXPECT_EQ(m.vertices[4], Eigen::Vector3f(0.5f, 1.5f, 0.0f));
  EXPECT_EQ(m.colors[0], Color3u8(255, 0, 128));
  ASSERT_EQ(m.faces.size(), 3u);
  EXPECT_EQ(m.faces[2], Eigen::Vector3i(0, 3, 4));
}

TEST(ReadPly, HeaderErrorsNameTheLine) {
  const std::string where = "bad.ply";
  ExpectInputError([&] { ParsePly("", where); }, {where, "not a PLY"});
  ExpectInputError([&] { ParsePly("PLY\nformat ascii 1.0\nend_header\n", where); },
                   {where, "first line must be 'ply'"});
  ExpectInputError([&] { ParsePly("ply\nformat ebcdic 1.0\nend_header\n", where); },
                   {where, "line 2", "unknown format 'ebcdic'"});
  ExpectInputError([&] { ParsePly("ply\nformat ascii 1.0\nelement vertex 3\n", where); },
                   {where, "no end_header"});
  ExpectInputError(
      [&] {
        ParsePly(
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float32 x\n"
            "property quad y\nend_header\n",
            where);
      },
      {where, "line 5", "unknown type 'quad'"});
  ExpectInputError(
      [&] { ParsePly("ply\nformat ascii 1.0\nproperty float x\nend_header\n", where); },
      {where, "line 3", "property before any element"});
  ExpectInputError(
      [&] { ParsePly("ply\nformat ascii 1.0\nelement vertex -4\nend_header\n", where); },
      {where, "line 3", "non-negative integer"});
  ExpectInputError([&] { ParsePly("ply\nformat ascii 1.0\nbogus line\nend_header\n", where); },
                   {where, "line 3", "unknown keyword 'bogus'"});
  ExpectInputError(
      [&] {
        ParsePly(
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
            "property float y\nend_header\n1 2\n",
            where);
      },
      {where, "element vertex has no property z"});
  ExpectInputError(
      [&] {
        ParsePly(
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
            "property float z\nelement face 1\nproperty list uchar float vertex_indices\n"
            "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
            where);
      },
      {where, "expected an integer type"});
}

std::string AsciiTriangle(const std::string& body) {
  return "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
         "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
         "end_header\n" +
         body;
}

TEST(ReadPly, AsciiBodyErrorsNameLineElementAndProperty) {
  const std::string where = "t.ply";
  ExpectInputError([&] { ParsePly(AsciiTriangle("0 0 0\n1 0\n0 1 0\n3 0 1 2\n"), where); },
                   {where, "line 11", "element vertex 1, property z", "missing value"});
  ExpectInputError([&] { ParsePly(AsciiTriangle("0 0 0\n1 0 0 7\n0 1 0\n3 0 1 2\n"), where); },
                   {where, "line 11", "more values than the header"});
  ExpectInputError([&] { ParsePly(AsciiTriangle("0 0 0\n1 0 x\n0 1 0\n3 0 1 2\n"), where); },
                   {where, "line 11", "property z", "'x' is not a valid float"});
  ExpectInputError([&] { ParsePly(AsciiTriangle("0 0 0\n1 0 nan\n0 1 0\n3 0 1 2\n"), where); },
                   {where, "element vertex 1", "not finite"});
  ExpectInputError([&] { ParsePly(AsciiTriangle("0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"), where); },
                   {where, "element face 0", "vertex index 3 out of range"});
  ExpectInputError([&] { ParsePly(AsciiTriangle("0 0 0\n1 0 0\n0 1 0\n2 0 1\n"), where); },
                   {where, "element face 0", "2 vertices, expected at least 3"});
  ExpectInputError([&] { ParsePly(AsciiTriangle("0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n"), where); },
                   {where, "'1.5' is not a valid int"});
  ExpectInputError([&] { ParsePly(AsciiTriangle("0 0 0\n1 0 0\n"), where); },
                   {where, "truncated", "element vertex 2", "header declares 3"});
  ExpectInputError([&] { ParsePly(AsciiTriangle("0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n"), where); },
                   {where, "'300' is not a valid uchar"});
}

TEST(ReadPly, BinaryTruncationNamesElementAndProperty) {
  const std::string where = "cut.ply";
  const std::string full = EncodePly(SampleMesh(true, true, true));
  // Cut inside the faces: the vertex block is complete.
  const size_t header_end = full.find("end_header\n") + 11;
  const size_t vertex_bytes = 50 * (12 + 12 + 4);
  ExpectInputError(
      [&] { ParsePly(full.substr(0, header_end + vertex_bytes + 13 * 10 + 5), where); },
      {where, "truncated", "element face 10, property vertex_indices"});
  // A header promising far more than the file holds fails before allocating.
  ExpectInputError(
      [&] {
        ParsePly(
            "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n"
            "property float x\nproperty float y\nproperty float z\nend_header\n0123456789",
            where);
      },
      {where, "truncated", "element vertex declares 4000000000"});
  ExpectInputError(
      [&] {
        std::string ply =
            "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
            "property float y\nproperty float z\nelement face 1\n"
            "property list int int vertex_indices\nend_header\n";
        ply += std::string(36, '\0');
        Put<int32_t>(ply, 1 << 30, false);
        ply += std::string(12, '\0');
        ParsePly(ply, where);
      },
      {where, "element face 0", "more than the file holds"});
}

TEST(ReadPly, MissingFileAndUnwritableDestination) {
  TempDir dir;
  ExpectInputError([&] { ReadPly(dir / "none.ply"); }, {"none.ply", "no such file"});
  const auto missing = dir / "nope/out.ply";
  ExpectInputError([&] { WritePly(missing, SampleMesh(false, false, true)); },
                   {missing.string(), "does not exist"});
}

TEST(Mesh, InconsistencyFindsMismatchedArrays) {
  Mesh m = SampleMesh(true, true, true);
  EXPECT_EQ(m.Inconsistency(), "");
  m.normals.pop_back();
  EXPECT_NE(m.Inconsistency().find("normals has 49 entries for 50 vertices"), std::string::npos);
  m = SampleMesh(false, false, true);
  m.faces[3][1] = 50;
  EXPECT_NE(m.Inconsistency().find("face 3 refers to vertex 50"), std::string::npos);
}

}  // namespace
}  // namespace dome::io
