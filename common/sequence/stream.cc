#include "sequence/stream.h"

#include <zlib.h>

#include <algorithm>
#include <limits>
#include <opencv2/core.hpp>

#include "core/error.h"
#include "mesh/gltf.h"
#include "sequence/le_bytes.h"

namespace dome::sequence {

void StreamOptions::Check() const {
  video.Check();
  core::Require(step_mm >= 0 && step_mm <= 100, "export: step_mm", "must be 0 (derived) .. 100 mm");
}

namespace {

uint32_t Crc(std::string_view bytes) {
  return uint32_t(crc32(0L, reinterpret_cast<const Bytef*>(bytes.data()), uInt(bytes.size())));
}


void PutRecord(std::string* out, const char* tag, uint32_t instant, std::string_view payload) {
  out->append(tag, 4);
  PutU32(out, instant);
  PutU32(out, uint32_t(payload.size()));
  PutU32(out, Crc(payload));
  out->append(payload);
}


int Even(int v) { return v + (v & 1); }

// The atlas cell of meshes whose atlas does not follow the grid rule (resampled).
constexpr int kCellPx = 8;

}  // namespace

std::string EncodeStream(const Sequence& seq, const StreamOptions& options,
                         StreamSummary* summary) {
  options.Check();
  core::Require(!seq.instants.empty(), "export: sequence", "has no instant");
  // One box and one frame size for the whole sequence: static parts quantize the same
  // in every instant, and the video keeps one size.
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = -lo;
  int width = 2, height = 2;
  for (const auto& instant : seq.instants) {
    for (const auto& p : instant.textured.mesh.vertices) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  }
  if (lo.x() > hi.x()) lo = hi = Eigen::Vector3f::Zero();
  // An eighth of a voxel moves a vertex by at most 0.11 voxel: far inside the 1 voxel
  // the delivered geometry may differ from the meshes it came from.
  const double max_step =
      options.step_mm > 0 ? options.step_mm : (seq.voxel_mm > 0 ? seq.voxel_mm / 8 : 0);
  const QuantizedBox box = QuantizationFor(lo, hi, max_step);
  // The meshes first: their atlas grids set the video frame's size.
  std::vector<EncodedMesh> meshes;
  meshes.reserve(seq.instants.size());
  for (const auto& instant : seq.instants) {
    const auto grid = GridLayoutOf(instant.textured);
    meshes.push_back(EncodeMesh(instant.textured.mesh, box, grid ? grid->cell_px : kCellPx));
    width = std::max(width, Even(meshes.back().layout.width_px()));
    height = std::max(height, Even(meshes.back().layout.height_px()));
  }
  VideoEncoder video(width, height, seq.fps, options.video);
  StreamSummary s;
  s.step_mm = box.step_mm;
  s.width = width;
  s.height = height;
  std::vector<std::string> frames(seq.instants.size());
  auto take = [&](std::vector<VideoPacket> packets) {
    for (auto& p : packets) {
      DOME_CHECK(p.frame >= 0 && size_t(p.frame) < frames.size(), "packet of an unknown frame");
      frames[size_t(p.frame)] = std::move(p.bytes);
    }
  };
  for (size_t i = 0; i < seq.instants.size(); ++i)
    take(video.Encode(RelayAtlas(seq.instants[i].textured, meshes[i])));
  take(video.Flush());
  s.codec = video.codec();

  core::Json instants = core::Json::array();
  for (const auto& instant : seq.instants) {
    instants.push_back({{"name", instant.name},
                        {"timecode", instant.timecode.Text()},
                        {"start_s", instant.start_s},
                        {"triangles", meshes[&instant - seq.instants.data()].source_face.size()}});
  }
  const core::Json manifest = {
      {"format", "dome4d"},
      {"version", 1},
      {"fps", seq.fps},
      {"duration_s", seq.duration_s()},
      {"unit", "mm"},
      {"world_to_gltf", mesh::WorldToGltfMatrix()},
      {"video",
       {{"codec", s.codec},
        {"width", width},
        {"height", height},
        {"keyframe_every", options.video.keyframe_every},
        {"colour", "bt601-limited"}}},
      {"mesh",
       {{"codec", "draco-grid16"},
        {"origin_mm", {box.origin_mm.x(), box.origin_mm.y(), box.origin_mm.z()}},
        {"step_mm", box.step_mm}}},
      {"instants", instants}};
  const std::string json = core::DumpJson(manifest);
  std::string out(kStreamMagic, 8);
  PutU32(&out, uint32_t(json.size()));
  out += json;
  for (size_t i = 0; i < seq.instants.size(); ++i) {
    DOME_CHECK(!frames[i].empty(), "libx264 returned no packet for a frame");
    PutRecord(&out, "MESH", uint32_t(i), meshes[i].payload);
    PutRecord(&out, "TEXF", uint32_t(i), frames[i]);
    s.mesh_bytes += int64_t(meshes[i].payload.size());
    s.video_bytes += int64_t(frames[i].size());
  }
  s.bytes = int64_t(out.size());
  if (summary) *summary = s;
  return out;
}

ParsedStream ParseStream(std::string_view bytes, const std::string& where) {
  core::Require(bytes.size() >= 12 && bytes.substr(0, 8) == std::string_view(kStreamMagic, 8),
                where, "is not a dome 4D file (no DOME4D header)");
  const size_t m = GetU32(bytes, 8);
  core::Require(m <= bytes.size() - 12, where, "ends inside its manifest");
  ParsedStream out;
  try {
    out.manifest = core::Json::parse(bytes.substr(12, m));
    core::Require(out.manifest.at("format") == "dome4d" && out.manifest.at("version") == 1, where,
                  "manifest is not dome4d version 1");
    for (const auto& instant : out.manifest.at("instants"))
      out.instants.push_back({instant.at("name").get<std::string>(), {}, {}, ""});
  } catch (const nlohmann::json::exception& e) {
    throw core::InputError(where, std::string("manifest: ") + e.what());
  }
  size_t at = 12 + m;
  while (at < bytes.size()) {
    if (bytes.size() - at < 16) {
      // A header cut short: the instant it belongs to cannot be told; the first one
      // still missing a record is the one being written.
      break;
    }
    const std::string_view tag = bytes.substr(at, 4);
    const uint32_t instant = GetU32(bytes, at + 4), length = GetU32(bytes, at + 8),
                   crc = GetU32(bytes, at + 12);
    const bool mesh = tag == "MESH";
    if ((!mesh && tag != "TEXF") || instant >= out.instants.size()) {
      // Framing lost: nothing after this point can be trusted.
      for (auto& i : out.instants)
        if (i.mesh.empty() && i.texture.empty() && i.broken.empty())
          i.broken = "its records are missing (the file is damaged at byte " +
                     std::to_string(at) + ")";
      return out;
    }
    StreamInstant& target = out.instants[instant];
    const char* what = mesh ? "mesh" : "texture";
    if (length > bytes.size() - at - 16) {
      target.broken = std::string(what) + " record is cut short (" +
                      std::to_string(bytes.size() - at - 16) + " of " + std::to_string(length) +
                      " bytes)";
      break;
    }
    const std::string_view payload = bytes.substr(at + 16, length);
    if (Crc(payload) != crc) {
      target.broken = std::string(what) + " record fails its CRC-32 (damaged)";
    } else if (mesh) {
      target.mesh = payload;
    } else {
      target.texture = payload;
    }
    at += 16 + length;
  }
  for (auto& i : out.instants) {
    if (!i.broken.empty()) continue;
    if (i.mesh.empty() || i.texture.empty())
      i.broken = std::string(i.mesh.empty() ? "mesh" : "texture") +
                 " record is missing (the file ends before it)";
  }
  return out;
}

std::vector<DecodedInstant> DecodeStream(const ParsedStream& stream, const std::string& where,
                                         std::vector<std::string>* broken) {
  const auto& video = stream.manifest.at("video");
  const int width = video.at("width"), height = video.at("height");
  VideoDecoder decoder;
  std::vector<DecodedInstant> out;
  for (const auto& instant : stream.instants) {
    const std::string name = where + ": instant " + instant.name;
    if (!instant.broken.empty()) {
      if (broken) broken->push_back(name + ": " + instant.broken);
      continue;
    }
    try {
      DecodedInstant d;
      d.name = instant.name;
      DecodedMesh m = DecodeMeshPayload(instant.mesh, name);
      core::Require(m.layout.width_px() <= width && m.layout.height_px() <= height, name,
                    "atlas grid does not fit the video frame");
      d.textured.uv = GridUv(m.layout, int64_t(m.mesh.faces.size()), width, height);
      d.textured.mesh = std::move(m.mesh);
      std::vector<cv::Mat> frames = decoder.Decode(instant.texture, name);
      core::Require(frames.size() == 1, name, "texture record does not hold one video frame");
      core::Require(frames[0].cols == width && frames[0].rows == height, name,
                    "video frame is not the manifest's size");
      d.textured.atlas = frames[0];
      out.push_back(std::move(d));
    } catch (const core::InputError& e) {
      if (broken) broken->push_back(e.what());
    }
  }
  return out;
}

StreamCheck CheckStream(const Sequence& seq, std::string_view bytes, const std::string& where) {
  const ParsedStream parsed = ParseStream(bytes, where);
  StreamCheck check;
  const std::vector<DecodedInstant> decoded = DecodeStream(parsed, where, &check.broken);
  check.decoded = int(decoded.size());
  const auto& m = parsed.manifest.at("mesh");
  QuantizedBox box;
  for (int a = 0; a < 3; ++a) box.origin_mm[a] = m.at("origin_mm").at(a).get<float>();
  box.step_mm = m.at("step_mm").get<float>();
  double psnr_sum = 0;
  check.min_psnr_db = std::numeric_limits<double>::infinity();
  for (const auto& d : decoded) {
    const auto it = std::find_if(seq.instants.begin(), seq.instants.end(),
                                 [&](const SequenceInstant& i) { return i.name == d.name; });
    core::Require(it != seq.instants.end(), where, "instant " + d.name + " is not in the sequence");
    // The encoder is deterministic: encoding the source again gives the payload's
    // triangle order, which pairs every delivered corner with its source corner.
    const auto grid = GridLayoutOf(it->textured);
    const EncodedMesh e = EncodeMesh(it->textured.mesh, box, grid ? grid->cell_px : kCellPx);
    const io::Mesh& a = it->textured.mesh;
    const io::Mesh& b = d.textured.mesh;
    core::Require(e.source_face.size() == b.faces.size(), where,
                  "instant " + d.name + " has another triangle count than its encoding");
    check.collapsed_triangles += int64_t(a.faces.size() - b.faces.size());
    for (size_t f = 0; f < b.faces.size(); ++f)
      for (int k = 0; k < 3; ++k) {
        const int source_vertex = a.faces[e.source_face[f]][(k + e.rotation[f]) % 3];
        check.max_displacement_mm = std::max(
            check.max_displacement_mm,
            double((a.vertices[source_vertex] - b.vertices[b.faces[f][k]]).norm()));
      }
    // The video's loss: the atlas as laid out for the stream against the decoded frame.
    const cv::Mat laid = RelayAtlas(it->textured, e);
    const double psnr = cv::PSNR(laid, d.textured.atlas(cv::Rect(0, 0, laid.cols, laid.rows)));
    psnr_sum += psnr;
    check.min_psnr_db = std::min(check.min_psnr_db, psnr);
  }
  check.mean_psnr_db = decoded.empty() ? 0 : psnr_sum / double(decoded.size());
  if (decoded.empty()) check.min_psnr_db = 0;
  return check;
}

}  // namespace dome::sequence
