#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/json.h"
#include "io/file_util.h"
#include "io/ply.h"
#include "mesh/gltf.h"
#include "mesh/marching_cubes.h"
#include "mesh/mesh_test_util.h"
#include "mesh/texture.h"
#include "sequence/gltf_sequence.h"
#include "sequence/mesh_codec.h"
#include "sequence/sequence.h"
#include "sequence/stream.h"
#include "sequence/video.h"
#include "testing/expect_error.h"
#include "testing/run_command.h"
#include "testing/temp_dir.h"

namespace dome::sequence {
namespace {

namespace fs = std::filesystem;

// A textured sphere of `radius_vox` voxels (2 mm), shifted by `shift_mm` along x, with
// the grid atlas of mesh/texture.h painted one colour per face.
mesh::TexturedMesh Sphere(double radius_vox, float shift_mm) {
  const auto v = testing::SphereVolume(24, radius_vox);
  mesh::TexturedMesh t;
  t.mesh = mesh::MarchingCubes(v.grid, v.distance, v.weight);
  for (auto& p : t.mesh.vertices) p.x() += shift_mm;
  const auto layout = mesh::GridAtlasLayout::For(int64_t(t.mesh.faces.size()), 8);
  t.atlas = cv::Mat(layout.height_px(), layout.width_px(), CV_8UC3, cv::Scalar(128, 128, 128));
  for (size_t f = 0; f < t.mesh.faces.size(); ++f) {
    for (int m = 0; m < 3; ++m) {
      const Eigen::Vector2d c = layout.CornerTexel(int64_t(f), m);
      t.uv.emplace_back(float(c.x() / layout.width_px()), float(1.0 - c.y() / layout.height_px()));
    }
    const Eigen::Vector2d c = layout.CornerTexel(int64_t(f), 0);
    cv::circle(t.atlas, cv::Point(int(c.x()) + 2, int(c.y()) + 2), 1,
               cv::Scalar(double(f * 37 % 256), double(f * 91 % 256), 200), -1);
  }
  return t;
}

struct Output {
  testing::TempDir dir;
  std::vector<std::string> names = {"00-00-01-00", "00-00-01-01", "00-00-01-03"};
  std::vector<size_t> vertices;  // of each instant's mesh_decimated.ply
};

// An output folder as dome run writes it, for what export reads: per instant
// textured.glb and mesh_decimated.ply, and report.json with the voxel.
void WriteOutput(Output* out) {
  for (size_t i = 0; i < out->names.size(); ++i) {
    const mesh::TexturedMesh t = Sphere(5.0 + 1.5 * double(i), 10.0f * float(i));
    const fs::path dir = out->dir.path() / out->names[i];
    fs::create_directories(dir);
    mesh::WriteGlb(dir / "textured.glb", t);
    io::WritePly(dir / "mesh_decimated.ply", t.mesh);
    out->vertices.push_back(t.mesh.vertices.size());
  }
  io::WriteFileAtomically(out->dir.path() / "report.json",
                          R"({"volume": {"voxel_size_mm": 2.0, "dims": [24, 24, 24]}})");
}

TEST(Sequence, LoadsInstantsInTimecodeOrderOnTheTimeline) {
  Output out;
  WriteOutput(&out);
  fs::create_directories(out.dir.path() / "not-an-instant");
  const Sequence seq = LoadSequence(out.dir.path(), {});
  ASSERT_EQ(seq.instants.size(), 3u);
  EXPECT_EQ(seq.instants[0].name, "00-00-01-00");
  EXPECT_DOUBLE_EQ(seq.instants[1].start_s, 1.0 / 30);
  EXPECT_DOUBLE_EQ(seq.instants[2].start_s, 3.0 / 30);  // a frame without an instant
  EXPECT_DOUBLE_EQ(seq.duration_s(), 4.0 / 30);
  EXPECT_DOUBLE_EQ(seq.voxel_mm, 2.0);
  EXPECT_EQ(seq.instants[2].textured.mesh.vertices.size(), out.vertices[2]);
}

TEST(Sequence, MissingInstantIsNamedOrSkipped) {
  Output out;
  WriteOutput(&out);
  fs::remove(out.dir.path() / "00-00-01-01" / "textured.glb");
  io::WriteFileAtomically(out.dir.path() / "00-00-01-03" / "textured.glb", "glTF");
  testing::ExpectInputError([&] { LoadSequence(out.dir.path(), {}); },
                            {"instant 00-00-01-01", "textured.glb", "is missing", "--skip-missing"});
  LoadOptions skip;
  skip.skip_missing = true;
  const Sequence seq = LoadSequence(out.dir.path(), skip);
  ASSERT_EQ(seq.instants.size(), 1u);
  ASSERT_EQ(seq.skipped.size(), 2u);
  EXPECT_EQ(seq.skipped[0].name, "00-00-01-01");
  EXPECT_NE(seq.skipped[1].reason.find("not a glTF 2.0 binary"), std::string::npos);
  testing::ExpectInputError([&] { LoadSequence(out.dir.path() / "nothing", {}); },
                            {"nothing", "is not an output folder"});
  LoadOptions bad;
  bad.fps = 0;
  testing::ExpectInputError([&] { LoadSequence(out.dir.path(), bad); }, {"export: fps"});
}

// `dome export` as a user runs it: a missing instant stops it, named; --skip-missing
// writes the rest and lists what it left out; a bad format is refused by name.
TEST(ExportCommand, NamesOrSkipsAMissingInstant) {
  Output out;
  WriteOutput(&out);
  fs::remove(out.dir.path() / "00-00-01-01" / "textured.glb");
  const fs::path file = out.dir.path() / "seq.dome4d";
  const std::string args = "export " + out.dir.path().string() + " --out " + file.string();
  auto run = testing::RunDomeBinary(args);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.output.find("instant 00-00-01-01"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("--skip-missing"), std::string::npos) << run.output;
  EXPECT_FALSE(fs::exists(file));
  run = testing::RunDomeBinary(args + " --skip-missing --verify");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const core::Json line = core::Json::parse(run.output);
  EXPECT_EQ(line["instants"], 2);
  ASSERT_EQ(line["skipped"].size(), 1u);
  EXPECT_EQ(line["skipped"][0]["instant"], "00-00-01-01");
  EXPECT_EQ(line["verify"]["decoded"], 2);
  EXPECT_EQ(line["bytes"].get<size_t>(), fs::file_size(file));
  run = testing::RunDomeBinary(args + " --format usd");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.output.find("--format: must be dome4d or gltf-sequence, not 'usd'"),
            std::string::npos)
      << run.output;
}

// Blender (Debian's 3.4, headless) imports the file written by `dome export --format
// gltf-sequence` as one animated scene: one frame per timeline frame, exactly one
// instant's mesh visible at each, with that instant's decimated-mesh vertex count.
TEST(GltfSequence, BlenderPlaysOneInstantPerFrame) {
  if (!fs::exists("/usr/bin/blender")) GTEST_SKIP() << "Debian's blender is not installed";
  Output out;
  WriteOutput(&out);
  const fs::path glb = out.dir.path() / "sequence.glb";
  const auto run = testing::RunDomeBinary("export " + out.dir.path().string() + " --out " +
                                          glb.string() + " --format gltf-sequence");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const core::Json line = core::Json::parse(run.output);
  EXPECT_EQ(line["instants"], 3);
  EXPECT_EQ(line["bytes"].get<size_t>(), fs::file_size(glb));
  const fs::path json = out.dir.path() / "blender.json";
  const std::string cmd = "/usr/bin/blender -b --factory-startup --python-exit-code 1 --python " +
                          std::string(DOME_SOURCE_DIR) + "/tests/sequence/blender_sequence.py -- " +
                          glb.string() + " 30 " + json.string() + " > " +
                          (out.dir.path() / "blender.log").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << io::ReadFileBytes(out.dir.path() / "blender.log");
  const core::Json b = core::Json::parse(io::ReadFileBytes(json));
  // Instants at frames 0, 1 and 3 of the timeline: 4 frames, the third still the second
  // instant (STEP holds it until the next instant).
  const int start = b["frame_start"];
  EXPECT_EQ(start, 0);  // the first instant at time 0
  ASSERT_EQ(b["frames"].size(), 4u) << b.dump();
  const std::vector<std::string> want = {out.names[0], out.names[1], out.names[1], out.names[2]};
  for (size_t f = 0; f < 4; ++f) {
    const auto& frame = b["frames"][f];
    EXPECT_EQ(frame["frame"], start + int(f));
    ASSERT_EQ(frame["visible"].size(), 1u) << frame.dump();
    const std::string name = frame["visible"][0];
    EXPECT_EQ(name, want[f]);
  }
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(b["meshes"][out.names[i]].get<size_t>(), out.vertices[i]) << out.names[i];
  }
}

// The 4D file decodes back to the sequence: every triangle corner within the position
// grid's half-diagonal (and so within a voxel), the atlases through H.264 at a PSNR
// that keeps the painted colours.
TEST(Stream, DecodesToTheSequenceWithinTheGridStep) {
  Output out;
  WriteOutput(&out);
  const Sequence seq = LoadSequence(out.dir.path(), {});
  StreamSummary summary;
  const std::string file = EncodeStream(seq, {}, &summary);
  EXPECT_EQ(summary.bytes, int64_t(file.size()));
  EXPECT_FLOAT_EQ(summary.step_mm, 0.128f);  // the largest 2^k um within 2 mm voxel / 8
  const StreamCheck check = CheckStream(seq, file, "t.dome4d");
  EXPECT_EQ(check.decoded, 3);
  EXPECT_TRUE(check.broken.empty());
  EXPECT_LE(check.max_displacement_mm, summary.step_mm * std::sqrt(3.0) / 2 + 1e-4);
  EXPECT_GT(check.max_displacement_mm, 0.0);
  // The fixture's atlas is one saturated dot per triangle, the hardest case for 4:2:0
  // chroma (the paper take's atlases: 29-30 dB at the default CRF 26).
  EXPECT_GE(check.min_psnr_db, 20.0);
  StreamOptions fine;
  fine.video.crf = 0;
  const StreamCheck lossless = CheckStream(seq, EncodeStream(seq, fine, nullptr), "f.dome4d");
  EXPECT_GT(lossless.min_psnr_db, check.min_psnr_db + 1.0);  // what is left: 4:2:0 chroma
  const ParsedStream parsed = ParseStream(file, "t.dome4d");
  EXPECT_EQ(parsed.manifest["instants"][2]["timecode"], "00:00:01:03");
  EXPECT_EQ(parsed.manifest["video"]["codec"].get<std::string>().substr(0, 5), "avc1.");
  // Triangles delivered: the source's less those whose corners share a grid point.
  const size_t delivered = parsed.manifest["instants"][1]["triangles"].get<size_t>();
  EXPECT_LE(delivered, seq.instants[1].textured.mesh.faces.size());
  EXPECT_GE(delivered, seq.instants[1].textured.mesh.faces.size() * 95 / 100);
  int64_t source_triangles = 0, delivered_triangles = 0;
  for (size_t i = 0; i < 3; ++i) {
    source_triangles += int64_t(seq.instants[i].textured.mesh.faces.size());
    delivered_triangles += parsed.manifest["instants"][i]["triangles"].get<int64_t>();
  }
  EXPECT_EQ(check.collapsed_triangles, source_triangles - delivered_triangles);
}

// Re-laying a grid atlas for the codecs' triangle order moves each triangle's texels
// with it: one colour per triangle stays that triangle's colour.
TEST(Stream, RelaidAtlasKeepsEveryTrianglesTexels) {
  mesh::TexturedMesh t = Sphere(6.0, 0);
  const auto layout = *GridLayoutOf(t);
  const int s = layout.cell_px;
  auto colour = [](size_t f) {
    return cv::Vec3b(uint8_t(f * 37 % 251), uint8_t(f * 91 % 241), uint8_t(f * 13 % 239));
  };
  for (size_t f = 0; f < t.mesh.faces.size(); ++f) {
    const int64_t cell = int64_t(f) / 2;
    const int x0 = int(cell % layout.columns) * s, y0 = int(cell / layout.columns) * s;
    for (int ty = 0; ty < s; ++ty)
      for (int tx = 0; tx < s; ++tx)
        if ((tx + ty < s - 1 ? 0 : 1) == int(f % 2)) t.atlas.at<cv::Vec3b>(y0 + ty, x0 + tx) = colour(f);
  }
  const EncodedMesh e = EncodeMesh(t.mesh, QuantizationFor({-50, -50, -50}, {50, 50, 50}, 0.01), s);
  // On a fine grid only marching cubes' own zero-area triangles collapse.
  EXPECT_GE(e.source_face.size(), t.mesh.faces.size() * 99 / 100);
  int rotated = 0, moved = 0;
  for (size_t f = 0; f < e.source_face.size(); ++f) {
    rotated += e.rotation[f] != 0;
    moved += e.source_face[f] != int(f);
  }
  EXPECT_GT(rotated, 0);  // the test sees both
  EXPECT_GT(moved, 0);
  const cv::Mat laid = RelayAtlas(t, e);
  int64_t wrong = 0;
  for (size_t f = 0; f < e.source_face.size(); ++f) {
    const int64_t cell = int64_t(f) / 2;
    const int x0 = int(cell % e.layout.columns) * s, y0 = int(cell / e.layout.columns) * s;
    for (int ty = 0; ty < s; ++ty)
      for (int tx = 0; tx < s; ++tx)
        if ((tx + ty < s - 1 ? 0 : 1) == int(f % 2))
          wrong += laid.at<cv::Vec3b>(y0 + ty, x0 + tx) != colour(size_t(e.source_face[f]));
  }
  EXPECT_EQ(wrong, 0);
  // The payload decodes to the same triangles, corner for corner.
  const DecodedMesh d = DecodeMeshPayload(e.payload, "payload");
  ASSERT_EQ(d.mesh.faces.size(), e.source_face.size());
  for (size_t f = 0; f < d.mesh.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const auto& src = t.mesh.vertices[t.mesh.faces[e.source_face[f]][(k + e.rotation[f]) % 3]];
      EXPECT_LE((src - d.mesh.vertices[d.mesh.faces[f][k]]).norm(), 0.1f);
    }
}

// A file cut short or damaged costs the instants it hits, named, and no others.
TEST(Stream, TruncatedOrDamagedRecordsNameTheirInstant) {
  Output out;
  WriteOutput(&out);
  const Sequence seq = LoadSequence(out.dir.path(), {});
  const std::string file = EncodeStream(seq, {}, nullptr);
  const std::string cut = file.substr(0, file.size() - 100);
  std::vector<std::string> broken;
  const auto decoded = DecodeStream(ParseStream(cut, "cut.dome4d"), "cut.dome4d", &broken);
  ASSERT_EQ(decoded.size(), 2u);
  ASSERT_EQ(broken.size(), 1u);
  EXPECT_NE(broken[0].find("instant 00-00-01-03: texture record is cut short"), std::string::npos)
      << broken[0];
  // One flipped byte inside the first mesh payload: its CRC fails, the rest decode.
  std::string damaged = file;
  const ParsedStream parsed = ParseStream(file, "x");
  const size_t at = size_t(parsed.instants[0].mesh.data() - file.data()) + 10;
  damaged[at] = char(damaged[at] ^ 0x5a);
  broken.clear();
  EXPECT_EQ(DecodeStream(ParseStream(damaged, "d.dome4d"), "d.dome4d", &broken).size(), 2u);
  ASSERT_EQ(broken.size(), 1u);
  EXPECT_NE(broken[0].find("instant 00-00-01-00: mesh record fails its CRC-32"), std::string::npos)
      << broken[0];
  testing::ExpectInputError([&] { ParseStream("PK\x03\x04 zip", "z.dome4d"); },
                            {"z.dome4d", "not a dome 4D file"});
  testing::ExpectInputError([&] { ParseStream(file.substr(0, 40), "h.dome4d"); },
                            {"h.dome4d", "ends inside its manifest"});
}

// An instant whose mesh is empty (the volume missed the scene) travels as an empty
// instant; the others are unaffected.
TEST(Stream, AnEmptyInstantStaysEmpty) {
  Output out;
  WriteOutput(&out);
  Sequence seq = LoadSequence(out.dir.path(), {});
  seq.instants[1].textured.mesh = io::Mesh();
  seq.instants[1].textured.uv.clear();
  seq.instants[1].textured.atlas = cv::Mat(8, 8, CV_8UC3, cv::Scalar(128, 128, 128));
  const StreamCheck check = CheckStream(seq, EncodeStream(seq, {}, nullptr), "e.dome4d");
  EXPECT_EQ(check.decoded, 3);
  EXPECT_TRUE(check.broken.empty());
  // In the glTF sequence it is a node without a mesh (glTF has no empty mesh).
  const std::string glb = EncodeGltfSequence(seq);
  uint32_t json_length = 0;
  std::memcpy(&json_length, glb.data() + 12, 4);
  const core::Json j = core::Json::parse(glb.substr(20, json_length));
  EXPECT_TRUE(j["nodes"][1].contains("mesh"));
  EXPECT_FALSE(j["nodes"][2].contains("mesh"));
  EXPECT_EQ(j["nodes"][2]["name"], "00-00-01-01");
  EXPECT_EQ(j["meshes"].size(), 2u);
}

TEST(Stream, BadOptionsAreNamed) {
  StreamOptions o;
  o.video.crf = 60;
  testing::ExpectInputError([&] { o.Check(); }, {"export: crf"});
  o = {};
  o.video.preset = "warp";
  testing::ExpectInputError([&] { o.Check(); }, {"export: preset", "warp"});
  o = {};
  o.video.keyframe_every = 0;
  testing::ExpectInputError([&] { o.Check(); }, {"export: keyframe_every"});
  o = {};
  o.step_mm = -1;
  testing::ExpectInputError([&] { o.Check(); }, {"export: step_mm"});
  o = {};
  o.video.threads = -2;
  testing::ExpectInputError([&] { o.Check(); }, {"export: threads"});
  // An atlas grid past what H.264 4:2:0 frames hold.
  testing::ExpectInputError([&] { VideoEncoder(8194, 8, 30, {}); },
                            {"export: video frame", "8192"});
}

// Damaged input the CRC cannot catch (a payload or manifest written wrong) is named.
TEST(Stream, MalformedPayloadsAndManifestsAreNamed) {
  testing::ExpectInputError([&] { DecodeMeshPayload("short", "m"); }, {"m", "ends early"});
  std::string header;
  for (float v : {0.0f, 0.0f, 0.0f, 1.0f}) header.append(reinterpret_cast<const char*>(&v), 4);
  for (uint32_t v : {8u, 4u}) header.append(reinterpret_cast<const char*>(&v), 4);
  testing::ExpectInputError([&] { DecodeMeshPayload(header + "not draco at all", "m"); },
                            {"m", "not a Draco mesh"});
  std::string bad_grid = header;
  const uint32_t zero = 0;
  bad_grid.replace(16, 4, reinterpret_cast<const char*>(&zero), 4);
  testing::ExpectInputError([&] { DecodeMeshPayload(bad_grid, "m"); }, {"m", "out of range"});
  auto file_with = [](const std::string& manifest) {
    std::string f(kStreamMagic, 8);
    const uint32_t n = uint32_t(manifest.size());
    f.append(reinterpret_cast<const char*>(&n), 4);
    return f + manifest;
  };
  testing::ExpectInputError([&] { ParseStream(file_with(R"({"format": "mp4"})"), "f.dome4d"); },
                            {"f.dome4d", "manifest"});
  testing::ExpectInputError([&] { ParseStream(file_with("{not json"), "f.dome4d"); },
                            {"f.dome4d", "manifest"});
}

TEST(Sequence, UnreadableReportIsNamed) {
  Output out;
  WriteOutput(&out);
  io::WriteFileAtomically(out.dir.path() / "report.json", R"({"volume": {}})");
  testing::ExpectInputError([&] { LoadSequence(out.dir.path(), {}); },
                            {"report.json", "volume.voxel_size_mm"});
}

}  // namespace
}  // namespace dome::sequence
