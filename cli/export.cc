// `dome export OUT --out FILE [--format dome4d|gltf-sequence] [--fps F] [--skip-missing]`:
// the whole sequence of an output folder as one file (sequence/): a streamable 4D file
// (sequence/stream.h) or one binary glTF that plays as an animation (sequence/
// gltf_sequence.h). Prints one JSON line: what was written, its size and bitrate, the
// instants skipped.
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "cli/commands.h"
#include "core/error.h"
#include "core/json.h"
#include "io/file_util.h"
#include "sequence/gltf_sequence.h"
#include "sequence/sequence.h"
#include "sequence/stream.h"

namespace dome::cli {

void AddExportCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand(
      "export", "Write an output folder's instants as one sequence file (4D stream or glTF)");
  struct Args {
    std::string out, file, format = "dome4d";
    sequence::LoadOptions load;
    sequence::StreamOptions stream;
    bool verify = false;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("OUT", a->out, "output folder (OUT/<instant>/textured.glb)")->required();
  cmd->add_option("--out", a->file, "file to write")->required();
  cmd->add_option("--format", a->format, "dome4d (streamable 4D file) or gltf-sequence")
      ->capture_default_str();
  cmd->add_option("--fps", a->load.fps,
                  "timeline frames per second, the take's VITC rate (instants are placed by "
                  "their timecodes)")
      ->capture_default_str();
  cmd->add_flag("--skip-missing", a->load.skip_missing,
                "leave out instants without a readable textured mesh (listed) instead of "
                "stopping");
  cmd->add_option("--crf", a->stream.video.crf,
                  "dome4d: x264 constant rate factor of the atlas video (0 lossless .. 51)")
      ->capture_default_str();
  cmd->add_option("--preset", a->stream.video.preset, "dome4d: x264 preset (ultrafast .. veryslow)")
      ->capture_default_str();
  cmd->add_option("--keyframe-every", a->stream.video.keyframe_every,
                  "dome4d: a keyframe every N instants (1: each instant decodes alone)")
      ->capture_default_str();
  cmd->add_option("--threads", a->stream.video.threads, "dome4d: encoder threads (0: all cores)")
      ->capture_default_str();
  cmd->add_option("--step-mm", a->stream.step_mm,
                  "dome4d: position grid step, mm (0: an eighth of the session's voxel)")
      ->capture_default_str();
  cmd->add_flag("--verify", a->verify,
                "dome4d: decode the file written and report its distance to the meshes and "
                "atlases it came from");
  cmd->callback([=] {
    core::Require(a->format == "dome4d" || a->format == "gltf-sequence", "--format",
                  "must be dome4d or gltf-sequence, not '" + a->format + "'");
    const auto t0 = std::chrono::steady_clock::now();
    const sequence::Sequence seq = sequence::LoadSequence(a->out, a->load);
    const auto t1 = std::chrono::steady_clock::now();
    const bool stream = a->format == "dome4d";
    sequence::StreamSummary summary;
    const std::string bytes = stream ? sequence::EncodeStream(seq, a->stream, &summary)
                                     : sequence::EncodeGltfSequence(seq);
    io::WriteFileAtomically(a->file, bytes);
    const auto t2 = std::chrono::steady_clock::now();
    core::Json skipped = core::Json::array();
    for (const auto& s : seq.skipped) skipped.push_back({{"instant", s.name}, {"reason", s.reason}});
    const double n = double(seq.instants.size());
    core::Json line = {
        {"export", a->file},
        {"format", a->format},
        {"instants", seq.instants.size()},
        {"skipped", skipped},
        {"bytes", bytes.size()},
        {"duration_s", seq.duration_s()},
        // Each instant one frame of playback at 30 frames a second.
        {"mbit_per_s_at_30_instants_per_s", double(bytes.size()) * 8 / n * 30 / 1e6},
        {"read_s", std::chrono::duration<double>(t1 - t0).count()},
        {"encode_s_per_instant", std::chrono::duration<double>(t2 - t1).count() / n}};
    if (stream) {
      line["video"] = {{"codec", summary.codec},
                       {"width", summary.width},
                       {"height", summary.height},
                       {"bytes", summary.video_bytes},
                       {"crf", a->stream.video.crf}};
      line["mesh"] = {{"bytes", summary.mesh_bytes}, {"step_mm", summary.step_mm}};
      line["voxel_mm"] = seq.voxel_mm;
    }
    if (stream && a->verify) {
      const sequence::StreamCheck c = sequence::CheckStream(seq, bytes, a->file);
      line["verify"] = {{"decoded", c.decoded},
                        {"broken", c.broken},
                        {"max_displacement_mm", c.max_displacement_mm},
                        {"collapsed_triangles", c.collapsed_triangles},
                        {"atlas_psnr_db_min", c.min_psnr_db},
                        {"atlas_psnr_db_mean", c.mean_psnr_db}};
    }
    std::printf("%s\n", core::DumpJson(line).c_str());
    *exit_code = 0;
  });
}

}  // namespace dome::cli
