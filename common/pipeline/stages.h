// The pipeline's stages as pure functions of serialized inputs (SPEC.md "Pipeline"):
// what a worker runs for a job (proto/runtime.proto Job) and what the master runs to
// stitch slabs. No sockets, no file system: bytes and protos in, bytes and protos out,
// calling the same library functions as `dome stereo` and `dome fuse`.
//
// Blob formats (all content-addressed by the runtime):
//   rig       TAKE/rig.json text (take/rig.h)
//   frame     the take's PNG of one camera at one instant (take/take.h)
//   stereo    runtime.StereoOutput: one range image (depth mm, reliability) per window
//   slab      fusion/volume.h EncodeSlab
//   mesh      binary little-endian PLY, world mm (io/ply.h)
// Errors: core::InputError naming the job and the blob at fault.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "fusion/volume.h"
#include "io/mesh.h"
#include "runtime.pb.h"
#include "stereo/multi_baseline.h"

namespace dome::pipeline {

// Output names of the jobs (runtime.Output.name). A stereo job's result also carries
// its output files, named by their paths under OUT/<instant>/ (stereo/take_stereo.h
// EncodeStereoFiles): the workers encode them, so the master only checks and writes.
inline constexpr const char* kStereoOutput = "stereo";
inline constexpr const char* kSlabOutput = "slab";
inline constexpr const char* kDecimatedOutput = "mesh_decimated.ply";
inline constexpr const char* kTexturedObj = "textured.obj";
inline constexpr const char* kTexturedMtl = "textured.mtl";
inline constexpr const char* kTexturedPng = "textured.png";
inline constexpr const char* kTexturedGlb = "textured.glb";  // the same mesh, one binary glTF

// The bytes of a job's blobs, in the job's order (shared with a worker's blob cache).
using JobBlobs = std::vector<std::shared_ptr<const std::string>>;

struct PreparedFusion;

// What a worker keeps from one job for the next, so that work shared by jobs is done
// once: the decoded range images and fusion tables of the last instant fused (every
// slab job of an instant needs the same ones; building them costs about as much as
// fusing a slab). Keyed by the job's settings and input blob hashes, so a job's outputs
// are the same bytes with or without a memo. One set is kept (tens of MB for the paper
// rig). Not thread-safe: one job at a time.
class JobMemo {
 public:
  JobMemo();
  ~JobMemo();
  JobMemo(const JobMemo&) = delete;
  JobMemo& operator=(const JobMemo&) = delete;

  // The prepared fusion for `key`, built by `build` unless it is the one kept.
  PreparedFusion* Fusion(const std::string& key,
                         const std::function<std::unique_ptr<PreparedFusion>()>& build);
  // How many times fusion inputs were prepared (a figure for tests and logs).
  int64_t fusion_preparations() const { return fusion_preparations_; }

 private:
  std::string fusion_key_;
  std::unique_ptr<PreparedFusion> fusion_;
  int64_t fusion_preparations_ = 0;
};

// Runs one job; `blobs` are the bytes of job.blobs, in the job's order. Returns its
// outputs (names above). `memo` (optional) carries shared work between the jobs of
// one worker. `threads` <= 0: all hardware threads.
std::vector<runtime::Output> RunJob(const runtime::Job& job, const JobBlobs& blobs,
                                    JobMemo* memo = nullptr);

// Stereo results <-> the "stereo" blob.
std::string EncodeStereoOutput(const stereo::StereoResult& result);
stereo::StereoResult DecodeStereoOutput(const std::string& bytes, const std::string& where);

// Surface extraction (the master's stage): the slabs of one instant, fetched one at a
// time in plane order by `slab(index)` (index 0 = planes from 0), stitched by
// StreamingMarchingCubes; memory is bounded by one slab.
io::Mesh ExtractSurface(const fusion::VolumeGrid& grid, int num_slabs,
                        const std::function<std::string(int index)>& slab);
// The same from slabs already decoded (fusion/volume.h DecodeSlab).
io::Mesh ExtractSurfaceFromSlabs(
    const fusion::VolumeGrid& grid, int num_slabs,
    const std::function<std::shared_ptr<const fusion::Slab>(int index)>& slab);

// The PLY bytes dome writes for meshes (binary little-endian, "units mm").
std::string EncodeMeshPly(const io::Mesh& mesh);

}  // namespace dome::pipeline
