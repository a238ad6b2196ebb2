#include "mesh/gltf.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <limits>
#include <unordered_map>
#include <vector>

#include "core/error.h"
#include "core/json.h"
#include "io/file_util.h"
#include "io/image_io.h"

namespace dome::mesh {

int GlbBuilder::AddView(const void* bytes, size_t size, int target) {
  while (bin_.size() % 4) bin_.push_back('\0');
  core::Json view = {{"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", size}};
  if (target) view["target"] = target;
  views_.push_back(std::move(view));
  bin_.append(static_cast<const char*>(bytes), size);
  return int(views_.size()) - 1;
}

int GlbBuilder::AddAccessor(int view, int component_type, size_t count, const char* type,
                            bool normalized, const core::Json& min_max) {
  core::Json a = {
      {"bufferView", view}, {"componentType", component_type}, {"count", count}, {"type", type}};
  if (normalized) a["normalized"] = true;
  for (const auto& [key, value] : min_max.items()) a[key] = value;
  accessors_.push_back(std::move(a));
  return int(accessors_.size()) - 1;
}

std::string GlbBuilder::Finish(const core::Json& document) {
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

core::Json WorldToGltfMatrix() {
  return {0.001, 0, 0, 0, 0, 0, -0.001, 0, 0, 0.001, 0, 0, 0, 0, 0, 1};
}

namespace {

constexpr int kFloat = kGltfFloat, kUnsignedInt = kGltfUnsignedInt,
              kUnsignedByte = kGltfUnsignedByte;
constexpr int kArrayTarget = kGltfArrayBuffer, kElementTarget = kGltfElementArrayBuffer;

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

// The scene of one mesh node. World mm, z up -> glTF metres, y up.
core::Json SceneOf(core::Json document) {
  document["scene"] = 0;
  document["scenes"] = {{{"nodes", {0}}}};
  document["nodes"] = {{{"mesh", 0}, {"matrix", WorldToGltfMatrix()}}};
  return document;
}

// Appends `value` to the array document[key] (made when missing); returns its index.
int Append(core::Json* document, const char* key, core::Json value) {
  core::Json& array = (*document)[key];
  if (array.is_null()) array = core::Json::array();
  array.push_back(std::move(value));
  return int(array.size()) - 1;
}

}  // namespace

int GlbBuilder::AddTexturedMesh(const TexturedMesh& textured, core::Json* document,
                                const std::string* atlas_png) {
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
  const std::string encoded =
      atlas_png ? std::string() : io::EncodePng(textured.atlas, io::PngEncoding::kFast);
  const std::string& png = atlas_png ? *atlas_png : encoded;
  const size_t nv = xyz.size() / 3;
  const int pos = AddAccessor(AddView(xyz.data(), xyz.size() * 4, kArrayTarget), kFloat, nv,
                              "VEC3", false, MinMax(xyz));
  const int tex =
      AddAccessor(AddView(uv.data(), uv.size() * 4, kArrayTarget), kFloat, nv, "VEC2", false);
  const int idx = AddAccessor(AddView(index.data(), index.size() * 4, kElementTarget),
                              kUnsignedInt, index.size(), "SCALAR", false);
  const int image = Append(document, "images",
                           {{"bufferView", AddView(png.data(), png.size(), 0)},
                            {"mimeType", "image/png"}});
  if (!document->contains("samplers"))
    (*document)["samplers"] = {{{"magFilter", 9729}, {"minFilter", 9729}}};
  const int texture = Append(document, "textures", {{"sampler", 0}, {"source", image}});
  const int material =
      Append(document, "materials",
             {{"pbrMetallicRoughness",
               {{"baseColorTexture", {{"index", texture}}},
                {"metallicFactor", 0},
                {"roughnessFactor", 1}}},
              {"doubleSided", true}});
  return Append(document, "meshes",
                {{"primitives",
                  {{{"attributes", {{"POSITION", pos}, {"TEXCOORD_0", tex}}},
                    {"indices", idx},
                    {"material", material},
                    {"mode", 4}}}}});
}

std::string EncodeGlb(const TexturedMesh& textured, const std::string* atlas_png) {
  GlbBuilder b;
  core::Json document = core::Json::object();
  b.AddTexturedMesh(textured, &document, atlas_png);
  return b.Finish(SceneOf(std::move(document)));
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
  core::Json document = {{"meshes", {{{"primitives", {std::move(primitive)}}}}}};
  return b.Finish(SceneOf(std::move(document)));
}

void WriteGlb(const std::filesystem::path& path, const TexturedMesh& textured) {
  io::WriteFileAtomically(path, EncodeGlb(textured));
}

void WriteGlb(const std::filesystem::path& path, const io::Mesh& mesh) {
  io::WriteFileAtomically(path, EncodeGlb(mesh));
}

}  // namespace dome::mesh

namespace dome::mesh {
namespace {

// The bytes of accessor `index` of `json` in `bin`, checked against the component type,
// element type and count the reader expects.
std::string_view AccessorBytes(const core::Json& json, std::string_view bin, int index,
                               int component_type, const char* type, size_t element_bytes,
                               size_t* count, const std::string& where) {
  const std::string what = where + ": accessor " + std::to_string(index);
  const auto& accessors = json.at("accessors");
  core::Require(index >= 0 && size_t(index) < accessors.size(), what, "does not exist");
  const auto& a = accessors[size_t(index)];
  core::Require(a.value("componentType", 0) == component_type &&
                    a.value("type", std::string()) == type,
                what, std::string("must be ") + type + " of component type " +
                          std::to_string(component_type));
  *count = a.at("count").get<size_t>();
  const auto& views = json.at("bufferViews");
  const int v = a.value("bufferView", -1);
  core::Require(v >= 0 && size_t(v) < views.size(), what, "has no buffer view");
  const auto& view = views[size_t(v)];
  const size_t offset = view.value("byteOffset", size_t(0)) + a.value("byteOffset", size_t(0));
  const size_t length = *count * element_bytes;
  core::Require(!view.contains("byteStride") || view["byteStride"].get<size_t>() == element_bytes,
                what, "must be tightly packed");
  core::Require(offset <= bin.size() && length <= bin.size() - offset &&
                    length <= view.value("byteLength", size_t(0)),
                what, "runs past the end of the BIN chunk");
  return bin.substr(offset, length);
}

}  // namespace

TexturedMesh DecodeTexturedGlb(std::string_view glb, const std::string& where) {
  auto u32 = [&](size_t at) {
    uint32_t v = 0;
    std::memcpy(&v, glb.data() + at, 4);
    return v;
  };
  core::Require(glb.size() >= 20 && glb.substr(0, 4) == "glTF" && u32(4) == 2, where,
                "is not a glTF 2.0 binary (GLB) file");
  core::Require(u32(8) == glb.size(), where,
                "is " + std::to_string(glb.size()) + " bytes, its header says " +
                    std::to_string(u32(8)) + " (truncated?)");
  const size_t json_length = u32(12);
  core::Require(glb.substr(16, 4) == "JSON" && 20 + json_length + 8 <= glb.size(), where,
                "has no JSON chunk followed by a BIN chunk");
  const size_t bin_at = 20 + json_length;
  const size_t bin_length = u32(bin_at);
  core::Require(glb.substr(bin_at + 4, 4) == std::string_view("BIN\0", 4) &&
                    bin_at + 8 + bin_length <= glb.size(),
                where, "has no complete BIN chunk");
  const std::string_view bin = glb.substr(bin_at + 8, bin_length);
  core::Json json;
  try {
    json = core::Json::parse(glb.substr(20, json_length));
  } catch (const std::exception& e) {
    throw core::InputError(where, std::string("JSON chunk: ") + e.what());
  }
  try {
    const auto& meshes = json.at("meshes");
    core::Require(meshes.size() == 1 && meshes[0].at("primitives").size() == 1, where,
                  "must hold one mesh of one primitive");
    const auto& primitive = meshes[0]["primitives"][0];
    core::Require(primitive.value("mode", 4) == 4, where, "primitive must be triangles");
    const auto& attributes = primitive.at("attributes");
    size_t nv = 0, nt = 0, ni = 0;
    const std::string_view xyz =
        AccessorBytes(json, bin, attributes.at("POSITION").get<int>(), kFloat, "VEC3", 12, &nv,
                      where);
    const std::string_view uv = AccessorBytes(json, bin, attributes.at("TEXCOORD_0").get<int>(),
                                              kFloat, "VEC2", 8, &nt, where);
    const std::string_view index = AccessorBytes(json, bin, primitive.at("indices").get<int>(),
                                                 kUnsignedInt, "SCALAR", 4, &ni, where);
    core::Require(nt == nv && ni % 3 == 0, where,
                  "needs one texture coordinate per vertex and whole triangles");
    // The base colour image of the primitive's material.
    const auto& material = json.at("materials").at(primitive.at("material").get<size_t>());
    const auto& texture = json.at("textures").at(
        material.at("pbrMetallicRoughness").at("baseColorTexture").at("index").get<size_t>());
    const auto& image = json.at("images").at(texture.at("source").get<size_t>());
    const auto& view = json.at("bufferViews").at(image.at("bufferView").get<size_t>());
    const size_t at = view.value("byteOffset", size_t(0)), length = view.at("byteLength");
    core::Require(at <= bin.size() && length <= bin.size() - at, where,
                  "image runs past the end of the BIN chunk");
    TexturedMesh out;
    out.atlas = io::DecodeImage(std::string_view(bin.data() + at, length), io::ImageMode::kBgr8,
                                where + ": the atlas image");

    std::vector<float> p(nv * 3), t(nv * 2);
    std::vector<uint32_t> corner(ni);
    std::memcpy(p.data(), xyz.data(), xyz.size());
    std::memcpy(t.data(), uv.data(), uv.size());
    std::memcpy(corner.data(), index.data(), index.size());
    // Corners with the same position bits are one vertex (EncodeGlb copies each face
    // corner from the mesh's vertex).
    struct Key {
      uint32_t x, y, z;
      bool operator==(const Key&) const = default;
    };
    struct Hash {
      size_t operator()(const Key& k) const {
        return (size_t(k.x) * 73856093u) ^ (size_t(k.y) * 19349663u) ^ (size_t(k.z) * 83492791u);
      }
    };
    std::unordered_map<Key, int, Hash> vertex_of;
    std::vector<int> welded(nv);
    for (size_t v = 0; v < nv; ++v) {
      Key k;
      std::memcpy(&k, &p[3 * v], 12);
      auto [it, fresh] = vertex_of.emplace(k, int(out.mesh.vertices.size()));
      if (fresh) out.mesh.vertices.emplace_back(p[3 * v], p[3 * v + 1], p[3 * v + 2]);
      welded[v] = it->second;
    }
    out.mesh.faces.reserve(ni / 3);
    out.uv.reserve(ni);
    for (size_t c = 0; c < ni; c += 3) {
      Eigen::Vector3i face;
      for (int m = 0; m < 3; ++m) {
        const uint32_t v = corner[c + m];
        core::Require(v < nv, where, "index " + std::to_string(v) + " past the vertices");
        face[m] = welded[v];
        out.uv.emplace_back(t[2 * v], 1.0f - t[2 * v + 1]);
      }
      out.mesh.faces.push_back(face);
    }
    return out;
  } catch (const nlohmann::json::exception& e) {
    throw core::InputError(where, std::string("JSON chunk: ") + e.what());
  }
}

TexturedMesh ReadTexturedGlb(const std::filesystem::path& path) {
  return DecodeTexturedGlb(io::ReadFileBytes(path), path.string());
}

}  // namespace dome::mesh
