#include "sequence/mesh_codec.h"

#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <unordered_map>
#include <vector>

#include "core/error.h"
#include "sequence/le_bytes.h"

namespace dome::sequence {
namespace {


// Reads the payload's fields in order; every read is bounds-checked.
class Reader {
 public:
  Reader(std::string_view bytes, const std::string& where) : bytes_(bytes), where_(where) {}
  uint32_t U32() { return GetU32(Take(4), 0); }
  float F32() {
    float v;
    std::memcpy(&v, Take(4).data(), 4);
    return v;
  }
  std::string_view Rest() { return Take(bytes_.size() - at_); }

 private:
  std::string_view Take(size_t n) {
    core::Require(n <= bytes_.size() - at_, where_, "mesh payload ends early");
    std::string_view v = bytes_.substr(at_, n);
    at_ += n;
    return v;
  }
  std::string_view bytes_;
  std::string where_;
  size_t at_ = 0;
};

}  // namespace

std::optional<mesh::GridAtlasLayout> GridLayoutOf(const mesh::TexturedMesh& t) {
  const int64_t faces = int64_t(t.mesh.faces.size());
  if (faces == 0 || t.uv.size() != size_t(faces) * 3 || t.atlas.empty()) return std::nullopt;
  // The rule's column count for this many faces; the cell edge from the atlas width.
  const auto probe = mesh::GridAtlasLayout::For(faces, 1);
  if (t.atlas.cols % probe.columns != 0) return std::nullopt;
  const auto layout = mesh::GridAtlasLayout::For(faces, t.atlas.cols / probe.columns);
  if (layout.width_px() != t.atlas.cols || layout.height_px() != t.atlas.rows) return std::nullopt;
  const double w = layout.width_px(), h = layout.height_px();
  for (int64_t f = 0; f < faces; ++f) {
    for (int m = 0; m < 3; ++m) {
      const Eigen::Vector2d c = layout.CornerTexel(f, m);
      const Eigen::Vector2f& uv = t.uv[size_t(f) * 3 + m];
      // Half a thousandth of a texel: float rounding, never a different corner.
      if (std::abs(uv.x() * w - c.x()) > 5e-4 || std::abs((1.0 - uv.y()) * h - c.y()) > 5e-4)
        return std::nullopt;
    }
  }
  return layout;
}

QuantizedBox QuantizationFor(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi,
                             double max_step_mm) {
  const double extent = std::max(1e-3, double((hi - lo).maxCoeff()));
  // The finest power-of-two multiple of a micrometre that spans the extent in 16 bits.
  double finest = 1e-3;
  while (extent / finest > 65535.0) finest *= 2;
  double step = finest;
  while (step * 2 <= max_step_mm) step *= 2;
  QuantizedBox box;
  box.origin_mm = lo;
  box.step_mm = float(step);
  // 16 bits must still reach hi with the coarser step (it does: step >= finest).
  return box;
}

namespace {

using Grid3 = std::array<uint16_t, 3>;

struct TriangleKey {
  Grid3 a, b, c;
  bool operator==(const TriangleKey&) const = default;
};
struct TriangleHash {
  size_t operator()(const TriangleKey& k) const {
    size_t h = 0;
    for (const Grid3* p : {&k.a, &k.b, &k.c})
      for (uint16_t v : *p) h = h * 1000003u ^ v;
    return h;
  }
};
// The triangle's corners rotated to start at its smallest grid point (orientation
// kept); *first is the corner it starts at.
TriangleKey Canonical(const Grid3& a, const Grid3& b, const Grid3& c, int* first) {
  *first = a <= b && a <= c ? 0 : (b <= c ? 1 : 2);
  const Grid3* t[3] = {&a, &b, &c};
  return {*t[*first], *t[(*first + 1) % 3], *t[(*first + 2) % 3]};
}

// The faces and grid points of a Draco mesh with a uint16 x 3 POSITION attribute.
bool ReadDraco(std::string_view bytes, std::vector<Grid3>* points,
               std::vector<std::array<uint32_t, 3>>* faces) {
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) return false;
  const std::unique_ptr<draco::Mesh>& mesh = decoded.value();
  const draco::PointAttribute* pos = mesh->GetNamedAttribute(draco::GeometryAttribute::POSITION);
  if (pos == nullptr || pos->num_components() != 3) return false;
  points->resize(mesh->num_points());
  for (uint32_t p = 0; p < mesh->num_points(); ++p) {
    if (!pos->ConvertValue<uint16_t, 3>(pos->mapped_index(draco::PointIndex(p)), (*points)[p].data()))
      return false;
  }
  faces->resize(mesh->num_faces());
  for (uint32_t f = 0; f < mesh->num_faces(); ++f) {
    const auto& face = mesh->face(draco::FaceIndex(f));
    for (int k = 0; k < 3; ++k) (*faces)[f][k] = face[k].value();
  }
  return true;
}

}  // namespace

EncodedMesh EncodeMesh(const io::Mesh& m, const QuantizedBox& box, int cell_px) {
  core::Require(m.Inconsistency().empty(), "export: mesh", m.Inconsistency());
  const size_t nv = m.vertices.size(), nf = m.faces.size();
  std::vector<Grid3> q(nv);
  for (size_t v = 0; v < nv; ++v) {
    for (int a = 0; a < 3; ++a) {
      const double c = std::round((double(m.vertices[v][a]) - box.origin_mm[a]) / box.step_mm);
      core::Require(c >= 0 && c <= 65535, "export: mesh",
                    "vertex " + std::to_string(v) + " lies outside the sequence's box");
      q[v][a] = uint16_t(c);
    }
  }
  // Triangles that keep three distinct grid points; Draco's builder merges equal points.
  std::vector<int> kept;
  kept.reserve(nf);
  for (size_t f = 0; f < nf; ++f) {
    const auto& t = m.faces[f];
    if (q[t[0]] != q[t[1]] && q[t[1]] != q[t[2]] && q[t[0]] != q[t[2]]) kept.push_back(int(f));
  }
  EncodedMesh out;
  out.layout = mesh::GridAtlasLayout::For(0, cell_px);
  auto header = [&](std::string* payload) {
    for (int a = 0; a < 3; ++a) PutF32(payload, box.origin_mm[a]);
    PutF32(payload, box.step_mm);
    PutU32(payload, uint32_t(out.layout.cell_px));
    PutU32(payload, uint32_t(out.layout.columns));
  };
  if (kept.empty()) {  // an empty instant (Draco codes no empty mesh): the header alone
    header(&out.payload);
    return out;
  }
  draco::TriangleSoupMeshBuilder builder;
  builder.Start(int(kept.size()));
  const int pos = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_UINT16);
  for (size_t i = 0; i < kept.size(); ++i) {
    const auto& t = m.faces[kept[i]];
    builder.SetAttributeValuesForFace(pos, draco::FaceIndex(uint32_t(i)), q[t[0]].data(),
                                      q[t[1]].data(), q[t[2]].data());
  }
  std::unique_ptr<draco::Mesh> mesh = builder.Finalize();
  DOME_CHECK(mesh != nullptr, "draco: the mesh builder failed");
  draco::Encoder encoder;
  encoder.SetEncodingMethod(draco::MESH_EDGEBREAKER_ENCODING);
  draco::EncoderBuffer buffer;
  const draco::Status status = encoder.EncodeMeshToBuffer(*mesh, &buffer);
  core::Require(status.ok(), "export: mesh", std::string("Draco refused it: ") + status.error_msg());
  const std::string_view draco_bytes(buffer.data(), buffer.size());

  // Where each payload triangle came from: decode what the page will see and match its
  // triangles to the source's by their grid corners in cyclic order.
  std::vector<Grid3> points;
  std::vector<std::array<uint32_t, 3>> faces;
  DOME_CHECK(ReadDraco(draco_bytes, &points, &faces), "Draco does not read back its own output");
  std::unordered_map<TriangleKey, std::vector<int>, TriangleHash> faces_of;
  for (int f : kept) {
    int first;
    const auto& t = m.faces[f];
    faces_of[Canonical(q[t[0]], q[t[1]], q[t[2]], &first)].push_back(f);
  }
  out.source_face.reserve(faces.size());
  out.rotation.reserve(faces.size());
  for (const auto& face : faces) {
    int first_decoded;
    const TriangleKey key =
        Canonical(points[face[0]], points[face[1]], points[face[2]], &first_decoded);
    auto it = faces_of.find(key);
    DOME_CHECK(it != faces_of.end() && !it->second.empty(), "Draco returned a triangle not given");
    const int sf = it->second.back();
    it->second.pop_back();
    int first_source;
    const auto& t = m.faces[sf];
    Canonical(q[t[0]], q[t[1]], q[t[2]], &first_source);
    out.source_face.push_back(sf);
    // decoded corner k = canonical corner k - first_decoded = source corner
    // k - first_decoded + first_source.
    out.rotation.push_back(uint8_t((first_source - first_decoded + 3) % 3));
  }
  out.layout = mesh::GridAtlasLayout::For(int64_t(faces.size()), cell_px);
  header(&out.payload);
  out.payload.append(draco_bytes);
  return out;
}

cv::Mat RelayAtlas(const mesh::TexturedMesh& source, const EncodedMesh& e) {
  core::Require(source.uv.size() == source.mesh.faces.size() * 3 && !source.atlas.empty() &&
                    source.atlas.type() == CV_8UC3,
                "export: atlas", "needs 3 texture coordinates per face and an 8-bit BGR atlas");
  const mesh::GridAtlasLayout& l = e.layout;
  const int s = l.cell_px;
  // A source made by the grid rule: each triangle owns the texels of its half-cell
  // (mesh/texture.cc: half 0 those above the anti-diagonal, half 1 the rest), and
  // samples stay where the bilinear footprint touches only those: at least 2 texels off
  // the anti-diagonal (barycentric weight of corner 0 >= 2 / (cell - 1)) and inside the
  // cell. Without it, a rotated triangle would take its neighbour's texels along an edge.
  const auto grid = GridLayoutOf(source);
  const double margin = grid && grid->cell_px > 3 ? 2.0 / (grid->cell_px - 1) : 0.0;
  cv::Mat map_x(l.height_px(), l.width_px(), CV_32FC1, cv::Scalar(-1));
  cv::Mat map_y(l.height_px(), l.width_px(), CV_32FC1, cv::Scalar(-1));
  const double sw = source.atlas.cols, sh = source.atlas.rows;
  for (size_t f = 0; f < e.source_face.size(); ++f) {
    const int sf = e.source_face[f], r = e.rotation[f];
    // Corners here (rule, this order) and in the source (pixel units, centres at +0.5),
    // paired: corner k here is source corner (k + r) % 3.
    Eigen::Vector2d c[3], p[3];
    for (int k = 0; k < 3; ++k) {
      c[k] = l.CornerTexel(int64_t(f), k);
      const Eigen::Vector2f& uv = source.uv[size_t(sf) * 3 + size_t((k + r) % 3)];
      p[k] = Eigen::Vector2d(double(uv.x()) * sw, (1.0 - double(uv.y())) * sh);
    }
    const int k0 = (3 - r) % 3;  // the corner here that is the source's corner 0
    Eigen::Vector2d box_lo(-1e9, -1e9), box_hi(1e9, 1e9);
    if (grid) {
      const int64_t cell = sf / 2;
      box_lo = Eigen::Vector2d(double(cell % grid->columns) * grid->cell_px + 0.5,
                               double(cell / grid->columns) * grid->cell_px + 0.5);
      box_hi = box_lo + Eigen::Vector2d::Constant(grid->cell_px - 1.0);
    }
    const double area =
        (c[1] - c[0]).x() * (c[2] - c[0]).y() - (c[2] - c[0]).x() * (c[1] - c[0]).y();
    const int64_t cell = int64_t(f) / 2;
    const int x0 = int(cell % l.columns) * s, y0 = int(cell / l.columns) * s;
    for (int ty = 0; ty < s; ++ty) {
      for (int tx = 0; tx < s; ++tx) {
        if ((tx + ty < s - 1 ? 0 : 1) != int(f % 2)) continue;  // the other triangle's
        const Eigen::Vector2d t(x0 + tx + 0.5, y0 + ty + 0.5);
        double w[3];
        w[1] = ((t - c[0]).x() * (c[2] - c[0]).y() - (c[2] - c[0]).x() * (t - c[0]).y()) / area;
        w[2] = ((c[1] - c[0]).x() * (t - c[0]).y() - (t - c[0]).x() * (c[1] - c[0]).y()) / area;
        w[0] = 1 - w[1] - w[2];
        if (w[k0] < margin) {
          const double rest = 1 - w[k0];
          const double scale = rest > 1e-12 ? (1 - margin) / rest : 0;
          for (int k = 0; k < 3; ++k) w[k] = k == k0 ? margin : w[k] * scale;
        }
        Eigen::Vector2d q = w[0] * p[0] + w[1] * p[1] + w[2] * p[2];
        q = q.cwiseMax(box_lo).cwiseMin(box_hi);
        map_x.at<float>(y0 + ty, x0 + tx) = float(q.x() - 0.5);
        map_y.at<float>(y0 + ty, x0 + tx) = float(q.y() - 0.5);
      }
    }
  }
  cv::Mat out;
  cv::remap(source.atlas, out, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

std::vector<Eigen::Vector2f> GridUv(const mesh::GridAtlasLayout& layout, int64_t faces,
                                    int frame_w, int frame_h) {
  std::vector<Eigen::Vector2f> uv(size_t(faces) * 3);
  for (int64_t f = 0; f < faces; ++f)
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector2d c = layout.CornerTexel(f, k);
      uv[size_t(f) * 3 + size_t(k)] =
          Eigen::Vector2f(float(c.x() / frame_w), float(1.0 - c.y() / frame_h));
    }
  return uv;
}

DecodedMesh DecodeMeshPayload(std::string_view payload, const std::string& where) {
  Reader r(payload, where);
  QuantizedBox box;
  for (int a = 0; a < 3; ++a) box.origin_mm[a] = r.F32();
  box.step_mm = r.F32();
  DecodedMesh out;
  out.layout.cell_px = int(r.U32());
  out.layout.columns = int(r.U32());
  core::Require(std::isfinite(box.step_mm) && box.step_mm > 0 && out.layout.cell_px >= 1 &&
                    out.layout.cell_px <= 256 && out.layout.columns >= 1 &&
                    out.layout.columns <= 65536,
                where, "mesh payload's grid or atlas layout is out of range");
  std::vector<Grid3> points;
  std::vector<std::array<uint32_t, 3>> faces;
  const std::string_view rest = r.Rest();
  core::Require(rest.empty() || ReadDraco(rest, &points, &faces), where,
                "mesh payload is not a Draco mesh with 16-bit grid positions");
  out.layout.rows =
      int((int64_t(faces.size() + 1) / 2 + out.layout.columns - 1) / out.layout.columns);
  io::Mesh& m = out.mesh;
  m.vertices.resize(points.size());
  for (size_t v = 0; v < points.size(); ++v)
    for (int a = 0; a < 3; ++a)
      m.vertices[v][a] = float(box.origin_mm[a] + double(points[v][a]) * box.step_mm);
  m.faces.resize(faces.size());
  for (size_t f = 0; f < faces.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      core::Require(faces[f][k] < points.size(), where, "mesh payload has a point past the end");
      m.faces[f][k] = int(faces[f][k]);
    }
  return out;
}

}  // namespace dome::sequence
