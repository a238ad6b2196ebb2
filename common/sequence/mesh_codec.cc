#include "sequence/mesh_codec.h"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <meshoptimizer.h>
#include <opencv2/imgproc.hpp>
#include <unordered_map>
#include <vector>

#include "core/error.h"

namespace dome::sequence {
namespace {

void Put32(std::string* out, uint32_t v) { out->append(reinterpret_cast<const char*>(&v), 4); }
void PutF(std::string* out, float v) { out->append(reinterpret_cast<const char*>(&v), 4); }
void PutBlock(std::string* out, const std::vector<unsigned char>& bytes, size_t n) {
  Put32(out, uint32_t(n));
  out->append(reinterpret_cast<const char*>(bytes.data()), n);
}

// Reads the payload's fields in order; every read is bounds-checked.
class Reader {
 public:
  Reader(std::string_view bytes, const std::string& where) : bytes_(bytes), where_(where) {}
  uint32_t U32() {
    uint32_t v;
    std::memcpy(&v, Take(4).data(), 4);
    return v;
  }
  float F32() {
    float v;
    std::memcpy(&v, Take(4).data(), 4);
    return v;
  }
  std::string_view Block() { return Take(U32()); }
  bool AtEnd() const { return at_ == bytes_.size(); }

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

std::string Deflate(const std::string& raw) {
  uLongf n = compressBound(uLong(raw.size()));
  std::string out(n, '\0');
  const int rc = compress2(reinterpret_cast<Bytef*>(out.data()), &n,
                           reinterpret_cast<const Bytef*>(raw.data()), uLong(raw.size()), 9);
  DOME_CHECK(rc == Z_OK, "zlib compress2 failed");
  out.resize(n);
  return out;
}

std::string Inflate(std::string_view z, const std::string& where) {
  z_stream s{};
  DOME_CHECK(inflateInit(&s) == Z_OK, "zlib inflateInit failed");
  s.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(z.data()));
  s.avail_in = uInt(z.size());
  std::string out;
  char buffer[1 << 16];
  int rc = Z_OK;
  while (rc == Z_OK) {
    s.next_out = reinterpret_cast<Bytef*>(buffer);
    s.avail_out = sizeof buffer;
    rc = inflate(&s, Z_NO_FLUSH);
    out.append(buffer, sizeof buffer - s.avail_out);
    if (rc == Z_BUF_ERROR && s.avail_in == 0) break;
  }
  inflateEnd(&s);
  core::Require(rc == Z_STREAM_END, where, "mesh payload is not a complete zlib stream");
  return out;
}

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

EncodedMesh EncodeMesh(const io::Mesh& m, const QuantizedBox& box, int cell_px) {
  core::Require(m.Inconsistency().empty(), "export: mesh", m.Inconsistency());
  const size_t nv = m.vertices.size(), nf = m.faces.size();
  std::vector<unsigned int> source(nf * 3);
  for (size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) source[3 * f + k] = unsigned(m.faces[f][k]);
  // Vertex-cache order, then vertices in order of first use: the orders both codecs
  // compress best. Unused vertices (none after decimation) are dropped.
  std::vector<unsigned int> index(nf * 3);
  meshopt_optimizeVertexCache(index.data(), source.data(), source.size(), nv);
  std::vector<unsigned int> remap(nv);
  const size_t used = meshopt_optimizeVertexFetchRemap(remap.data(), index.data(), index.size(), nv);
  std::vector<uint16_t> q(used * 4, 0);
  for (size_t v = 0; v < nv; ++v) {
    if (remap[v] == ~0u) continue;
    for (int a = 0; a < 3; ++a) {
      const double c = std::round((double(m.vertices[v][a]) - box.origin_mm[a]) / box.step_mm);
      core::Require(c >= 0 && c <= 65535, "export: mesh",
                    "vertex " + std::to_string(v) + " lies outside the sequence's box");
      q[4 * remap[v] + a] = uint16_t(c);
    }
  }
  for (auto& i : index) i = remap[i];
  std::vector<unsigned char> vb(meshopt_encodeVertexBufferBound(used, 8));
  vb.resize(meshopt_encodeVertexBuffer(vb.data(), vb.size(), q.data(), used, 8));
  std::vector<unsigned char> ib(meshopt_encodeIndexBufferBound(index.size(), used));
  ib.resize(meshopt_encodeIndexBuffer(ib.data(), ib.size(), index.data(), index.size()));

  EncodedMesh out;
  out.layout = mesh::GridAtlasLayout::For(int64_t(nf), cell_px);
  // Where each payload triangle came from: the index codec keeps the triangle order of
  // what it is given but may rotate corners, so decode what the page will see and match
  // its triangles to the source's (keyed by the rotation starting at the lowest vertex).
  std::vector<unsigned int> decoded(index.size());
  DOME_CHECK(meshopt_decodeIndexBuffer(decoded.data(), decoded.size(), 4, ib.data(), ib.size()) == 0,
             "meshopt index codec does not read back its own output");
  struct Key {
    unsigned a, b, c;
    bool operator==(const Key&) const = default;
  };
  struct Hash {
    size_t operator()(const Key& k) const {
      return (size_t(k.a) * 73856093u) ^ (size_t(k.b) * 19349663u) ^ (size_t(k.c) * 83492791u);
    }
  };
  auto canonical = [](unsigned a, unsigned b, unsigned c, int* first) {
    *first = a <= b && a <= c ? 0 : (b <= c ? 1 : 2);
    const unsigned t[3] = {a, b, c};
    return Key{t[*first], t[(*first + 1) % 3], t[(*first + 2) % 3]};
  };
  std::unordered_map<Key, std::vector<int>, Hash> faces_of;
  for (size_t f = 0; f < nf; ++f) {
    int first;
    faces_of[canonical(remap[source[3 * f]], remap[source[3 * f + 1]], remap[source[3 * f + 2]],
                       &first)]
        .push_back(int(f));
  }
  out.source_face.resize(nf);
  out.rotation.resize(nf);
  for (size_t f = 0; f < nf; ++f) {
    int first_decoded;
    const Key key = canonical(decoded[3 * f], decoded[3 * f + 1], decoded[3 * f + 2], &first_decoded);
    auto it = faces_of.find(key);
    DOME_CHECK(it != faces_of.end() && !it->second.empty(), "a triangle lost by the codecs");
    const int sf = it->second.back();
    it->second.pop_back();
    int first_source;
    canonical(remap[source[3 * sf]], remap[source[3 * sf + 1]], remap[source[3 * sf + 2]],
              &first_source);
    out.source_face[f] = sf;
    // decoded corner k = canonical corner (k - first_decoded) = source corner
    // (k - first_decoded + first_source).
    out.rotation[f] = uint8_t((first_source - first_decoded + 3) % 3);
  }
  std::string raw;
  Put32(&raw, uint32_t(used));
  Put32(&raw, uint32_t(nf));
  for (int a = 0; a < 3; ++a) PutF(&raw, box.origin_mm[a]);
  PutF(&raw, box.step_mm);
  Put32(&raw, uint32_t(out.layout.cell_px));
  Put32(&raw, uint32_t(out.layout.columns));
  PutBlock(&raw, vb, vb.size());
  PutBlock(&raw, ib, ib.size());
  out.payload = Deflate(raw);
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
  const std::string raw = Inflate(payload, where);
  Reader r(raw, where);
  const uint32_t nv = r.U32(), nf = r.U32();
  // A bound that no decimated mesh reaches, so a damaged count cannot ask for gigabytes.
  core::Require(nv <= (1u << 26) && nf <= (1u << 27), where, "mesh payload has impossible counts");
  QuantizedBox box;
  for (int a = 0; a < 3; ++a) box.origin_mm[a] = r.F32();
  box.step_mm = r.F32();
  DecodedMesh out;
  out.layout.cell_px = int(r.U32());
  out.layout.columns = int(r.U32());
  core::Require(out.layout.cell_px >= 1 && out.layout.cell_px <= 256 && out.layout.columns >= 1 &&
                    out.layout.columns <= 65536,
                where, "mesh payload's atlas grid is out of range");
  out.layout.rows = int((int64_t(nf + 1) / 2 + out.layout.columns - 1) / out.layout.columns);
  std::vector<uint16_t> q(size_t(nv) * 4);
  const std::string_view vb = r.Block();
  core::Require(meshopt_decodeVertexBuffer(q.data(), nv, 8,
                                           reinterpret_cast<const unsigned char*>(vb.data()),
                                           vb.size()) == 0,
                where, "mesh payload's vertices do not decode");
  std::vector<unsigned int> index(size_t(nf) * 3);
  const std::string_view ib = r.Block();
  core::Require(meshopt_decodeIndexBuffer(index.data(), index.size(), 4,
                                          reinterpret_cast<const unsigned char*>(ib.data()),
                                          ib.size()) == 0,
                where, "mesh payload's triangles do not decode");
  core::Require(r.AtEnd(), where, "mesh payload has bytes after its last field");
  io::Mesh& m = out.mesh;
  m.vertices.resize(nv);
  for (size_t v = 0; v < nv; ++v)
    for (int a = 0; a < 3; ++a)
      m.vertices[v][a] = float(box.origin_mm[a] + double(q[4 * v + a]) * box.step_mm);
  m.faces.resize(nf);
  for (size_t f = 0; f < nf; ++f) {
    for (int k = 0; k < 3; ++k) {
      core::Require(index[3 * f + k] < nv, where, "mesh payload has a vertex index past the end");
      m.faces[f][k] = int(index[3 * f + k]);
    }
  }
  return out;
}

}  // namespace dome::sequence
