// The mesh codec of the 4D file, chosen by measurement: for every instant of an output
// folder (OUT/<instant>/textured.glb), the bytes of its decimated mesh as
//   meshopt:  meshoptimizer's vertex codec (positions on the stream's 16-bit grid, vertices
//             in first-use order) and index codec after vertex-cache ordering, deflated
//             (what sequence/mesh_codec.h writes);
//   draco:    Draco's edgebreaker mesh coder (Debian libdraco-dev) at the same position
//             grid (quantization bits spanning the same step), speed 5 (its default);
// and the encode and decode seconds of each.
//
//   mesh_codec_bench OUT [--step-mm S]     (S default: an eighth of report.json's voxel)
//
// Prints one JSON line per instant and a total line. Both codecs keep the triangles'
// orientation and neither keeps their order or first corner, which the 4D file's atlas
// re-lay absorbs (sequence/stream.h), so the texture costs both the same.
#include <draco/compression/decode.h>
#include <draco/compression/encode.h>
#include <draco/mesh/triangle_soup_mesh_builder.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

#include "core/json.h"
#include "sequence/mesh_codec.h"
#include "sequence/sequence.h"

namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

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
  const int bits = int(std::ceil(std::log2(double((hi - lo).maxCoeff()) / box.step_mm + 1)));
  double totals[6] = {};
  int64_t triangles = 0;
  for (const auto& in : seq.instants) {
    const io::Mesh& m = in.textured.mesh;
    auto t0 = Clock::now();
    const std::string meshopt = sequence::EncodeMesh(m, box, 8).payload;
    const double meshopt_encode = Since(t0);
    t0 = Clock::now();
    sequence::DecodeMeshPayload(meshopt, in.name);
    const double meshopt_decode = Since(t0);

    t0 = Clock::now();
    draco::TriangleSoupMeshBuilder builder;
    builder.Start(int(m.faces.size()));
    const int pos = builder.AddAttribute(draco::GeometryAttribute::POSITION, 3, draco::DT_FLOAT32);
    for (size_t f = 0; f < m.faces.size(); ++f) {
      builder.SetAttributeValuesForFace(pos, draco::FaceIndex(uint32_t(f)),
                                        m.vertices[m.faces[f][0]].data(),
                                        m.vertices[m.faces[f][1]].data(),
                                        m.vertices[m.faces[f][2]].data());
    }
    std::unique_ptr<draco::Mesh> mesh = builder.Finalize();
    draco::Encoder encoder;
    encoder.SetAttributeQuantization(draco::GeometryAttribute::POSITION, bits);
    draco::EncoderBuffer buffer;
    if (!encoder.EncodeMeshToBuffer(*mesh, &buffer).ok()) return 1;
    const double draco_encode = Since(t0);
    t0 = Clock::now();
    draco::DecoderBuffer in_buffer;
    in_buffer.Init(buffer.data(), buffer.size());
    draco::Decoder decoder;
    auto decoded = decoder.DecodeMeshFromBuffer(&in_buffer);
    if (!decoded.ok()) return 1;
    const double draco_decode = Since(t0);

    const double row[6] = {double(meshopt.size()), meshopt_encode, meshopt_decode,
                           double(buffer.size()), draco_encode, draco_decode};
    for (int k = 0; k < 6; ++k) totals[k] += row[k];
    triangles += int64_t(m.faces.size());
    core::PrintJsonLine({{"instant", in.name},
                         {"triangles", m.faces.size()},
                         {"vertices", m.vertices.size()},
                         {"meshopt_bytes", meshopt.size()},
                         {"draco_bytes", buffer.size()},
                         {"meshopt_encode_s", meshopt_encode},
                         {"draco_encode_s", draco_encode},
                         {"meshopt_decode_s", meshopt_decode},
                         {"draco_decode_s", draco_decode}});
  }
  const double n = double(seq.instants.size());
  core::PrintJsonLine({{"instants", seq.instants.size()},
                       {"step_mm", box.step_mm},
                       {"draco_position_bits", bits},
                       {"meshopt_bytes_per_triangle", totals[0] / double(triangles)},
                       {"draco_bytes_per_triangle", totals[3] / double(triangles)},
                       {"meshopt_kbytes_per_instant", totals[0] / n / 1e3},
                       {"draco_kbytes_per_instant", totals[3] / n / 1e3},
                       {"meshopt_encode_s_per_instant", totals[1] / n},
                       {"draco_encode_s_per_instant", totals[4] / n},
                       {"meshopt_decode_s_per_instant", totals[2] / n},
                       {"draco_decode_s_per_instant", totals[5] / n}});
  return 0;
}
