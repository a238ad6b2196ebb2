#include "mesh/gltf.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "core/error.h"
#include "core/json.h"
#include "io/file_util.h"

namespace dome::mesh {
namespace {

// The BIN chunk under construction and the JSON of its buffer views and accessors.
class GlbBuilder {
 public:
  // Appends `bytes` as a buffer view (4-byte aligned); returns its index. `target` is
  // the view's bufferView.target, 0 for none (an image).
  int AddView(const void* bytes, size_t size, int target) {
    while (bin_.size() % 4) bin_.push_back('\0');
    core::Json view = {{"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", size}};
    if (target) view["target"] = target;
    views_.push_back(std::move(view));
    bin_.append(static_cast<const char*>(bytes), size);
    return int(views_.size()) - 1;
  }
  // An accessor over a whole view; min/max (an object with both) are required for POSITION.
  int AddAccessor(int view, int component_type, size_t count, const char* type, bool normalized,
                  const core::Json& min_max = core::Json::object()) {
    core::Json a = {
        {"bufferView", view}, {"componentType", component_type}, {"count", count}, {"type", type}};
    if (normalized) a["normalized"] = true;
    for (const auto& [key, value] : min_max.items()) a[key] = value;
    accessors_.push_back(std::move(a));
    return int(accessors_.size()) - 1;
  }
  // The GLB container of `document` (the scene, meshes, materials) with the asset,
  // buffers, views and accessors added; the JSON is printed by core/json.h.
  std::string Finish(const core::Json& document) {
    while (bin_.size() % 4) bin_.push_back('\0');
    core::Json j = {{"asset", {{"version", "2.0"}, {"generator", "dome"}}}};
    for (const auto& [key, value] : document.items()) j[key] = value;
    j["buffers"] = {{{"byteLength", bin_.size()}}};
    j["bufferViews"] = views_;
    j["accessors"] = accessors_;
    std::string json = core::DumpJson(j);
    while (json.size() % 4) json.push_back(' ');
    std::string out;
    auto put32 = [&](uint32_t v) { out.append(reinterpret_cast<const char*>(&v), 4); };
    const uint32_t total = uint32_t(12 + 8 + json.size() + 8 + bin_.size());
    out.reserve(total);
    out.append("glTF", 4);
    put32(2);
    put32(total);
    put32(uint32_t(json.size()));
    out.append("JSON", 4);
    out += json;
    put32(uint32_t(bin_.size()));
    out.append("BIN\0", 4);
    out += bin_;
    return out;
  }

 private:
  std::string bin_;
  core::Json views_ = core::Json::array(), accessors_ = core::Json::array();
};

constexpr int kFloat = 5126, kUnsignedInt = 5125, kUnsignedByte = 5121;
constexpr int kArrayTarget = 34962, kElementTarget = 34963;

core::Json MinMax(const std::vector<float>& xyz) {
  float lo[3] = {std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
                 std::numeric_limits<float>::max()};
  float hi[3] = {-lo[0], -lo[1], -lo[2]};
  for (size_t n = 0; n < xyz.size(); ++n) {
    lo[n % 3] = std::min(lo[n % 3], xyz[n]);
    hi[n % 3] = std::max(hi[n % 3], xyz[n]);
  }
  if (xyz.empty()) std::fill(lo, lo + 3, 0.0f), std::fill(hi, hi + 3, 0.0f);
  using core::FloatJson;
  return {{"min", {FloatJson(lo[0]), FloatJson(lo[1]), FloatJson(lo[2])}},
          {"max", {FloatJson(hi[0]), FloatJson(hi[1]), FloatJson(hi[2])}}};
}

// The scene of one mesh node. World mm, z up -> glTF metres, y up (column-major 4x4).
core::Json SceneOf(core::Json primitive) {
  return {{"scene", 0},
          {"scenes", {{{"nodes", {0}}}}},
          {"nodes",
           {{{"mesh", 0},
             {"matrix", {0.001, 0, 0, 0, 0, 0, -0.001, 0, 0, 0.001, 0, 0, 0, 0, 0, 1}}}}},
          {"meshes", {{{"primitives", {std::move(primitive)}}}}}};
}

}  // namespace

std::string EncodeGlb(const TexturedMesh& textured) {
  const io::Mesh& mesh = textured.mesh;
  core::Require(mesh.Inconsistency().empty(), "glTF: mesh", mesh.Inconsistency());
  core::Require(textured.uv.size() == mesh.faces.size() * 3, "glTF: uv",
                "must hold 3 texture coordinates per face");
  core::Require(!textured.atlas.empty() && textured.atlas.type() == CV_8UC3, "glTF: atlas",
                "must be an 8-bit BGR image");
  std::vector<float> xyz, uv;
  std::vector<uint32_t> index;
  xyz.reserve(mesh.faces.size() * 9);
  uv.reserve(mesh.faces.size() * 6);
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    for (int m = 0; m < 3; ++m) {
      const Eigen::Vector3f& p = mesh.vertices[mesh.faces[f][m]];
      xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
      uv.push_back(textured.uv[3 * f + m].x());
      uv.push_back(1.0f - textured.uv[3 * f + m].y());
      index.push_back(uint32_t(3 * f + m));
    }
  }
  std::vector<uchar> png;
  core::Require(cv::imencode(".png", textured.atlas, png), "glTF: atlas", "PNG encoding failed");
  GlbBuilder b;
  const size_t nv = xyz.size() / 3;
  const int pos = b.AddAccessor(b.AddView(xyz.data(), xyz.size() * 4, kArrayTarget), kFloat, nv,
                                "VEC3", false, MinMax(xyz));
  const int tex =
      b.AddAccessor(b.AddView(uv.data(), uv.size() * 4, kArrayTarget), kFloat, nv, "VEC2", false);
  const int idx = b.AddAccessor(b.AddView(index.data(), index.size() * 4, kElementTarget),
                                kUnsignedInt, index.size(), "SCALAR", false);
  const int image_view = b.AddView(png.data(), png.size(), 0);
  core::Json document = SceneOf({{"attributes", {{"POSITION", pos}, {"TEXCOORD_0", tex}}},
                                 {"indices", idx},
                                 {"material", 0},
                                 {"mode", 4}});
  document["materials"] = {
      {{"pbrMetallicRoughness",
        {{"baseColorTexture", {{"index", 0}}}, {"metallicFactor", 0}, {"roughnessFactor", 1}}},
       {"doubleSided", true}}};
  document["textures"] = {{{"sampler", 0}, {"source", 0}}};
  document["samplers"] = {{{"magFilter", 9729}, {"minFilter", 9729}}};
  document["images"] = {{{"bufferView", image_view}, {"mimeType", "image/png"}}};
  return b.Finish(document);
}

std::string EncodeGlb(const io::Mesh& mesh) {
  core::Require(mesh.Inconsistency().empty(), "glTF: mesh", mesh.Inconsistency());
  std::vector<float> xyz;
  xyz.reserve(mesh.vertices.size() * 3);
  for (const auto& p : mesh.vertices) xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
  std::vector<uint32_t> index;
  index.reserve(mesh.faces.size() * 3);
  for (const auto& f : mesh.faces)
    index.insert(index.end(), {uint32_t(f[0]), uint32_t(f[1]), uint32_t(f[2])});
  GlbBuilder b;
  const size_t nv = mesh.vertices.size();
  const int pos = b.AddAccessor(b.AddView(xyz.data(), xyz.size() * 4, kArrayTarget), kFloat, nv,
                                "VEC3", false, MinMax(xyz));
  core::Json attributes = {{"POSITION", pos}};
  if (mesh.HasColors()) {
    std::vector<uint8_t> rgba;
    rgba.reserve(nv * 4);
    for (size_t v = 0; v < nv; ++v) {
      const auto& c = mesh.colors[v];
      rgba.insert(rgba.end(), {c[0], c[1], c[2], mesh.HasAlphas() ? mesh.alphas[v] : uint8_t(255)});
    }
    const int col = b.AddAccessor(b.AddView(rgba.data(), rgba.size(), kArrayTarget), kUnsignedByte,
                                  nv, "VEC4", true);
    attributes["COLOR_0"] = col;
  }
  core::Json primitive = {{"attributes", std::move(attributes)}};
  if (mesh.HasFaces()) {
    const int idx = b.AddAccessor(b.AddView(index.data(), index.size() * 4, kElementTarget),
                                  kUnsignedInt, index.size(), "SCALAR", false);
    primitive["indices"] = idx;
    primitive["mode"] = 4;
  } else {
    primitive["mode"] = 0;  // points
  }
  return b.Finish(SceneOf(std::move(primitive)));
}

void WriteGlb(const std::filesystem::path& path, const TexturedMesh& textured) {
  io::WriteFileAtomically(path, EncodeGlb(textured));
}

void WriteGlb(const std::filesystem::path& path, const io::Mesh& mesh) {
  io::WriteFileAtomically(path, EncodeGlb(mesh));
}

}  // namespace dome::mesh
