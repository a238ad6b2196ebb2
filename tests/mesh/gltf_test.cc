#include "mesh/gltf.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "io/file_util.h"
#include "mesh/marching_cubes.h"
#include "mesh/mesh_test_util.h"
#include "mesh/texture.h"
#include "testing/expect_error.h"
#include "testing/temp_dir.h"

namespace dome::mesh {
namespace {

// A minimal JSON reader (objects, arrays, strings without escapes, numbers, literals):
// enough to follow the GLB's accessors independently of the writer's code.
struct Json {
  enum Kind { kNull, kNumber, kString, kArray, kObject, kBool } kind = kNull;
  double number = 0;
  std::string text;
  std::vector<Json> items;
  std::map<std::string, Json> fields;
  const Json& operator[](const std::string& k) const { return fields.at(k); }
  const Json& operator[](size_t i) const { return items.at(i); }
  bool Has(const std::string& k) const { return fields.count(k) > 0; }
};

class JsonParser {
 public:
  explicit JsonParser(const std::string& s) : s_(s) {}
  Json Parse() {
    Json j = Value();
    Space();
    EXPECT_EQ(pos_, s_.size()) << "trailing JSON";
    return j;
  }

 private:
  void Space() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
  }
  std::string String() {
    EXPECT_EQ(s_[pos_], '"');
    const size_t end = s_.find('"', pos_ + 1);
    std::string out = s_.substr(pos_ + 1, end - pos_ - 1);
    pos_ = end + 1;
    return out;
  }
  Json Value() {
    Space();
    Json j;
    const char c = s_.at(pos_);
    if (c == '{') {
      j.kind = Json::kObject;
      ++pos_;
      Space();
      if (s_[pos_] == '}') return ++pos_, j;
      while (true) {
        Space();
        const std::string key = String();
        Space();
        EXPECT_EQ(s_[pos_], ':');
        ++pos_;
        j.fields[key] = Value();
        Space();
        if (s_[pos_++] == '}') break;
      }
    } else if (c == '[') {
      j.kind = Json::kArray;
      ++pos_;
      Space();
      if (s_[pos_] == ']') return ++pos_, j;
      while (true) {
        j.items.push_back(Value());
        Space();
        if (s_[pos_++] == ']') break;
      }
    } else if (c == '"') {
      j.kind = Json::kString;
      j.text = String();
    } else if (s_.compare(pos_, 4, "true") == 0 || s_.compare(pos_, 5, "false") == 0) {
      j.kind = Json::kBool;
      j.number = s_[pos_] == 't';
      pos_ += s_[pos_] == 't' ? 4 : 5;
    } else if (s_.compare(pos_, 4, "null") == 0) {
      pos_ += 4;
    } else {
      j.kind = Json::kNumber;
      size_t used = 0;
      j.number = std::stod(s_.substr(pos_, 40), &used);
      pos_ += used;
    }
    return j;
  }
  const std::string& s_;
  size_t pos_ = 0;
};

struct Glb {
  Json json;
  std::string bin;
  // The bytes of accessor `a` (tightly packed views only, as glTF allows).
  std::string AccessorBytes(int a, size_t element_size) const {
    const Json& acc = json["accessors"][a];
    const Json& view = json["bufferViews"][size_t(acc["bufferView"].number)];
    const size_t offset = size_t(view["byteOffset"].number);
    const size_t count = size_t(acc["count"].number);
    EXPECT_LE(offset + count * element_size, bin.size());
    EXPECT_EQ(size_t(view["byteLength"].number), count * element_size);
    return bin.substr(offset, count * element_size);
  }
};

uint32_t U32(const std::string& b, size_t at) {
  uint32_t v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}

// The container as the GLB specification lays it out.
Glb ParseGlb(const std::string& b) {
  Glb g;
  EXPECT_GE(b.size(), 28u);
  EXPECT_EQ(b.substr(0, 4), "glTF");
  EXPECT_EQ(U32(b, 4), 2u);
  EXPECT_EQ(U32(b, 8), b.size());
  const uint32_t json_len = U32(b, 12);
  EXPECT_EQ(b.substr(16, 4), "JSON");
  EXPECT_EQ(json_len % 4, 0u);
  const std::string json = b.substr(20, json_len);
  const size_t bin_at = 20 + json_len;
  const uint32_t bin_len = U32(b, bin_at);
  EXPECT_EQ(b.substr(bin_at + 4, 4), std::string("BIN\0", 4));
  EXPECT_EQ(bin_len % 4, 0u);
  EXPECT_EQ(bin_at + 8 + bin_len, b.size());
  g.bin = b.substr(bin_at + 8, bin_len);
  g.json = JsonParser(json).Parse();
  EXPECT_EQ(g.json["asset"]["version"].text, "2.0");
  EXPECT_EQ(size_t(g.json["buffers"][0]["byteLength"].number), g.bin.size());
  return g;
}

TexturedMesh TwoTriangles() {
  TexturedMesh t;
  t.mesh.vertices = {{0, 0, 0}, {100, 0, 0}, {100, 50, 0}, {0, 50, 25}};
  t.mesh.faces = {{0, 1, 2}, {0, 2, 3}};
  t.uv = {{0.0f, 0.0f}, {1.0f, 0.0f}, {1.0f, 0.5f}, {0.0f, 0.0f}, {1.0f, 0.5f}, {0.0f, 1.0f}};
  t.atlas = cv::Mat(8, 16, CV_8UC3, cv::Scalar(10, 20, 30));
  t.atlas.at<cv::Vec3b>(3, 5) = cv::Vec3b(200, 100, 50);
  return t;
}

TEST(Gltf, TexturedGlbReadsBackFaceByFace) {
  const TexturedMesh t = TwoTriangles();
  const Glb g = ParseGlb(EncodeGlb(t));
  const Json& prim = g.json["meshes"][0]["primitives"][0];
  const int pos = int(prim["attributes"]["POSITION"].number);
  const int tex = int(prim["attributes"]["TEXCOORD_0"].number);
  const int idx = int(prim["indices"].number);
  EXPECT_EQ(int(g.json["accessors"][pos]["componentType"].number), 5126);
  EXPECT_EQ(g.json["accessors"][pos]["type"].text, "VEC3");
  const std::string p = g.AccessorBytes(pos, 12), uv = g.AccessorBytes(tex, 8),
                    ind = g.AccessorBytes(idx, 4);
  ASSERT_EQ(p.size(), 6u * 12);
  for (size_t f = 0; f < 2; ++f) {
    for (int m = 0; m < 3; ++m) {
      const uint32_t v = U32(ind, 4 * (3 * f + m));
      float xyz[3], st[2];
      std::memcpy(xyz, p.data() + 12 * v, 12);
      std::memcpy(st, uv.data() + 8 * v, 8);
      const Eigen::Vector3f& want = t.mesh.vertices[t.mesh.faces[f][m]];
      for (int a = 0; a < 3; ++a) EXPECT_EQ(xyz[a], want[a]);
      EXPECT_EQ(st[0], t.uv[3 * f + m].x());
      EXPECT_FLOAT_EQ(st[1], 1.0f - t.uv[3 * f + m].y());  // glTF: v down
    }
  }
  // Required POSITION bounds.
  const Json& acc = g.json["accessors"][pos];
  EXPECT_EQ(acc["min"][1].number, 0.0);
  EXPECT_EQ(acc["max"][0].number, 100.0);
  EXPECT_EQ(acc["max"][2].number, 25.0);
  // The embedded PNG decodes to the atlas.
  const Json& image = g.json["images"][0];
  EXPECT_EQ(image["mimeType"].text, "image/png");
  const Json& view = g.json["bufferViews"][size_t(image["bufferView"].number)];
  const std::string png =
      g.bin.substr(size_t(view["byteOffset"].number), size_t(view["byteLength"].number));
  const cv::Mat atlas =
      cv::imdecode(std::vector<uchar>(png.begin(), png.end()), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(atlas.size(), t.atlas.size());
  EXPECT_EQ(cv::norm(atlas, t.atlas, cv::NORM_INF), 0.0);
  // mm, z up -> metres, y up.
  const Json& matrix = g.json["nodes"][0]["matrix"];
  EXPECT_DOUBLE_EQ(matrix[0].number, 0.001);
  EXPECT_DOUBLE_EQ(matrix[6].number, -0.001);
  EXPECT_DOUBLE_EQ(matrix[9].number, 0.001);
}

TEST(Gltf, VertexColouredMeshSharesVertices) {
  const auto v = testing::SphereVolume(20, 6.0);
  io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  for (size_t i = 0; i < m.vertices.size(); ++i) {
    m.colors.push_back(io::Color3u8(uint8_t(i % 256), 7, uint8_t(255 - i % 256)));
  }
  const Glb g = ParseGlb(EncodeGlb(m));
  const Json& prim = g.json["meshes"][0]["primitives"][0];
  const int col = int(prim["attributes"]["COLOR_0"].number);
  EXPECT_TRUE(g.json["accessors"][col]["normalized"].number);
  const std::string c = g.AccessorBytes(col, 4);
  const std::string ind = g.AccessorBytes(int(prim["indices"].number), 4);
  const std::string p = g.AccessorBytes(int(prim["attributes"]["POSITION"].number), 12);
  ASSERT_EQ(c.size(), m.vertices.size() * 4);
  for (size_t i = 0; i < m.vertices.size(); ++i) {
    EXPECT_EQ(uint8_t(c[4 * i]), m.colors[i][0]);
    EXPECT_EQ(uint8_t(c[4 * i + 2]), m.colors[i][2]);
    EXPECT_EQ(uint8_t(c[4 * i + 3]), 255);
    float xyz[3];
    std::memcpy(xyz, p.data() + 12 * i, 12);
    EXPECT_EQ(xyz[0], m.vertices[i].x());
  }
  for (size_t f = 0; f < m.faces.size(); ++f) {
    for (int k = 0; k < 3; ++k) EXPECT_EQ(int(U32(ind, 4 * (3 * f + k))), m.faces[f][k]);
  }
}

// An independent reader: Open3D (Debian python3-open3d) loads the file; skipped where
// it is not installed.
TEST(Gltf, Open3dLoadsTheFile) {
  if (std::system("/usr/bin/python3 -c 'import open3d' > /dev/null 2>&1") != 0) {
    GTEST_SKIP() << "python3-open3d not installed";
  }
  testing::TempDir dir;
  const auto v = testing::SphereVolume(20, 6.0);
  const io::Mesh m = MarchingCubes(v.grid, v.distance, v.weight);
  const auto path = dir.path() / "sphere.glb";
  WriteGlb(path, m);
  const auto out = dir.path() / "counts.txt";
  const std::string cmd =
      "/usr/bin/python3 -c \"import open3d as o3d, numpy as np; m = "
      "o3d.io.read_triangle_mesh('" +
      path.string() + "'); p = np.asarray(m.vertices); open('" + out.string() +
      "', 'w').write('%d %d %.6f' % (len(p), len(m.triangles), np.abs(p).max()))\"";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::ifstream in(out);
  size_t nv = 0, nf = 0;
  double extent = 0;
  in >> nv >> nf >> extent;
  EXPECT_EQ(nf, m.faces.size());
  EXPECT_GT(nv, 0u);
  // The largest coordinate: 12 mm as written (raw) or 0.012 m (node transform applied).
  float raw = 0;
  for (const auto& p : m.vertices) raw = std::max(raw, p.cwiseAbs().maxCoeff());
  EXPECT_TRUE(std::abs(extent - raw) < 1e-3 || std::abs(extent - raw * 1e-3) < 1e-6) << extent;
}

TEST(Gltf, BadTexturedMeshIsRejected) {
  TexturedMesh t = TwoTriangles();
  t.uv.pop_back();
  testing::ExpectInputError([&] { EncodeGlb(t); }, {"glTF: uv", "3 texture coordinates"});
  t = TwoTriangles();
  t.atlas = cv::Mat();
  testing::ExpectInputError([&] { EncodeGlb(t); }, {"glTF: atlas"});
  t = TwoTriangles();
  t.mesh.faces.push_back(Eigen::Vector3i(0, 1, 9));
  t.uv.resize(9);
  testing::ExpectInputError([&] { EncodeGlb(t); }, {"glTF: mesh"});
}

// DecodeTexturedGlb gives back the mesh EncodeGlb was given: the same vertices (the face
// corners welded back), faces, texture coordinates and atlas, bit for bit.
TEST(Gltf, TexturedGlbDecodesToTheMeshItWasWrittenFrom) {
  const TexturedMesh t = TwoTriangles();
  const TexturedMesh back = DecodeTexturedGlb(EncodeGlb(t), "two.glb");
  ASSERT_EQ(back.mesh.vertices.size(), t.mesh.vertices.size());
  for (size_t v = 0; v < t.mesh.vertices.size(); ++v)
    EXPECT_EQ(back.mesh.vertices[v], t.mesh.vertices[v]);
  ASSERT_EQ(back.mesh.faces.size(), t.mesh.faces.size());
  for (size_t f = 0; f < t.mesh.faces.size(); ++f) EXPECT_EQ(back.mesh.faces[f], t.mesh.faces[f]);
  ASSERT_EQ(back.uv.size(), t.uv.size());
  for (size_t c = 0; c < t.uv.size(); ++c) {
    EXPECT_EQ(back.uv[c].x(), t.uv[c].x());
    EXPECT_FLOAT_EQ(back.uv[c].y(), t.uv[c].y());
  }
  ASSERT_EQ(back.atlas.size(), t.atlas.size());
  EXPECT_EQ(cv::norm(back.atlas, t.atlas, cv::NORM_INF), 0.0);
}

// The OBJ files are the same bytes on one thread or two, and a GLB given their PNG holds
// exactly those bytes (the atlas encoded once) and decodes to the same mesh and atlas.
TEST(Gltf, GlbHoldsTheObjFilesPngWhenGivenIt) {
  const TexturedMesh t = TwoTriangles();
  const TexturedObjFiles one = EncodeTexturedObj(t, "textured", 1);
  const TexturedObjFiles two = EncodeTexturedObj(t, "textured", 2);
  EXPECT_EQ(one.obj, two.obj);
  EXPECT_EQ(one.mtl, two.mtl);
  EXPECT_EQ(one.png, two.png);
  const std::string glb = EncodeGlb(t, &one.png);
  EXPECT_NE(glb.find(one.png), std::string::npos);
  const TexturedMesh back = DecodeTexturedGlb(glb, "shared.glb");
  EXPECT_EQ(back.mesh.faces.size(), t.mesh.faces.size());
  ASSERT_EQ(back.atlas.size(), t.atlas.size());
  EXPECT_EQ(cv::norm(back.atlas, t.atlas, cv::NORM_INF), 0.0);
}

TEST(Gltf, DamagedGlbIsRejectedByName) {
  const std::string glb = EncodeGlb(TwoTriangles());
  testing::ExpectInputError([&] { DecodeTexturedGlb(glb.substr(0, glb.size() - 9), "t.glb"); },
                            {"t.glb", "truncated"});
  testing::ExpectInputError([&] { DecodeTexturedGlb("solid ascii stl", "t.glb"); },
                            {"t.glb", "not a glTF 2.0 binary"});
  // A vertex-coloured GLB has no texture coordinates.
  io::Mesh m = TwoTriangles().mesh;
  testing::ExpectInputError([&] { DecodeTexturedGlb(EncodeGlb(m), "c.glb"); },
                            {"c.glb", "TEXCOORD_0"});
  testing::ExpectInputError([&] { ReadTexturedGlb("/nonexistent/t.glb"); },
                            {"/nonexistent/t.glb"});
}

}  // namespace
}  // namespace dome::mesh
