// The mesh codec of the 4D file, chosen by measurement: for every instant of an output
// folder (OUT/<instant>/textured.glb), the bytes of its decimated mesh as
//   draco:    what the 4D file sends (sequence/mesh_codec.h): Draco's edgebreaker coder
//             (Debian libdraco-dev) over the positions on the stream's 16-bit grid;
//   meshopt:  meshoptimizer's vertex codec (the same grid, vertices in first-use order)
//             and index codec after vertex-cache ordering, deflated (zlib level 9);
// and the encode and decode seconds of each.
//
//   mesh_codec_bench OUT [--step-mm S]     (S default: an eighth of report.json's voxel)
//
// Prints one JSON line per instant and a total line. Neither codec keeps the triangles'
// order or first corners; the 4D file's atlas re-lay absorbs that (sequence/stream.h), so
// the texture costs both the same.
#include <zlib.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <meshoptimizer.h>
#include <string>
#include <vector>

#include "core/json.h"
#include "sequence/mesh_codec.h"
#include "sequence/sequence.h"

namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

std::string Deflate(const std::vector<unsigned char>& raw) {
  uLongf n = compressBound(uLong(raw.size()));
  std::string out(n, '\0');
  compress2(reinterpret_cast<Bytef*>(out.data()), &n, raw.data(), uLong(raw.size()), 9);
  out.resize(n);
  return out;
}

// meshoptimizer's codecs over the grid positions, deflated; decoded back into *seconds.
size_t Meshopt(const dome::io::Mesh& m, const dome::sequence::QuantizedBox& box,
               double* encode_s, double* decode_s) {
  auto t0 = Clock::now();
  const size_t nv = m.vertices.size(), nf = m.faces.size();
  std::vector<unsigned int> source(nf * 3), index(nf * 3), remap(nv);
  for (size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) source[3 * f + k] = unsigned(m.faces[f][k]);
  meshopt_optimizeVertexCache(index.data(), source.data(), source.size(), nv);
  const size_t used = meshopt_optimizeVertexFetchRemap(remap.data(), index.data(), index.size(), nv);
  std::vector<uint16_t> q(used * 4, 0);
  for (size_t v = 0; v < nv; ++v) {
    if (remap[v] == ~0u) continue;
    for (int a = 0; a < 3; ++a)
      q[4 * remap[v] + a] = uint16_t(std::lround((m.vertices[v][a] - box.origin_mm[a]) / box.step_mm));
  }
  for (auto& i : index) i = remap[i];
  std::vector<unsigned char> vb(meshopt_encodeVertexBufferBound(used, 8));
  vb.resize(meshopt_encodeVertexBuffer(vb.data(), vb.size(), q.data(), used, 8));
  std::vector<unsigned char> ib(meshopt_encodeIndexBufferBound(index.size(), used));
  ib.resize(meshopt_encodeIndexBuffer(ib.data(), ib.size(), index.data(), index.size()));
  std::vector<unsigned char> raw(vb);
  raw.insert(raw.end(), ib.begin(), ib.end());
  const std::string z = Deflate(raw);
  *encode_s = Since(t0);
  t0 = Clock::now();
  std::vector<unsigned char> back(raw.size());
  uLongf n = uLongf(back.size());
  uncompress(back.data(), &n, reinterpret_cast<const Bytef*>(z.data()), uLong(z.size()));
  meshopt_decodeVertexBuffer(q.data(), used, 8, back.data(), vb.size());
  meshopt_decodeIndexBuffer(index.data(), index.size(), 4, back.data() + vb.size(), ib.size());
  *decode_s = Since(t0);
  return z.size();
}

}  // namespace

int main(int argc, char** argv) {
  using namespace dome;
  if (argc < 2) {
    std::fprintf(stderr, "usage: mesh_codec_bench OUT [--step-mm S]\n");
    return 2;
  }
  double step_mm = 0;
  for (int i = 2; i + 1 < argc; ++i)
    if (std::string(argv[i]) == "--step-mm") step_mm = std::stod(argv[i + 1]);
  const sequence::Sequence seq = sequence::LoadSequence(argv[1], {});
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e30f), hi = -lo;
  for (const auto& in : seq.instants)
    for (const auto& p : in.textured.mesh.vertices) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  if (step_mm <= 0) step_mm = seq.voxel_mm > 0 ? seq.voxel_mm / 8 : 0;
  const sequence::QuantizedBox box = sequence::QuantizationFor(lo, hi, step_mm);
  double total[6] = {};  // draco bytes, encode, decode; meshopt bytes, encode, decode
  int64_t triangles = 0;
  for (const auto& in : seq.instants) {
    const io::Mesh& m = in.textured.mesh;
    auto t0 = Clock::now();
    const sequence::EncodedMesh e = sequence::EncodeMesh(m, box, 8);
    const double draco_encode = Since(t0);
    t0 = Clock::now();
    sequence::DecodeMeshPayload(e.payload, in.name);
    const double draco_decode = Since(t0);
    double meshopt_encode = 0, meshopt_decode = 0;
    const size_t meshopt = Meshopt(m, box, &meshopt_encode, &meshopt_decode);
    const double row[6] = {double(e.payload.size()), draco_encode, draco_decode,
                           double(meshopt), meshopt_encode, meshopt_decode};
    for (int k = 0; k < 6; ++k) total[k] += row[k];
    triangles += int64_t(m.faces.size());
    core::PrintJsonLine({{"instant", in.name},
                         {"triangles", m.faces.size()},
                         {"vertices", m.vertices.size()},
                         {"draco_bytes", e.payload.size()},
                         {"meshopt_bytes", meshopt},
                         {"draco_encode_s", draco_encode},
                         {"meshopt_encode_s", meshopt_encode},
                         {"draco_decode_s", draco_decode},
                         {"meshopt_decode_s", meshopt_decode}});
  }
  const double n = double(seq.instants.size());
  core::PrintJsonLine({{"instants", seq.instants.size()},
                       {"step_mm", box.step_mm},
                       {"draco_bytes_per_triangle", total[0] / double(triangles)},
                       {"meshopt_bytes_per_triangle", total[3] / double(triangles)},
                       {"draco_kbytes_per_instant", total[0] / n / 1e3},
                       {"meshopt_kbytes_per_instant", total[3] / n / 1e3},
                       {"draco_encode_s_per_instant", total[1] / n},
                       {"meshopt_encode_s_per_instant", total[4] / n},
                       {"draco_decode_s_per_instant", total[2] / n},
                       {"meshopt_decode_s_per_instant", total[5] / n}});
  return 0;
}
