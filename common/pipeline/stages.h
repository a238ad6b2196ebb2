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

#include <functional>
#include <string>
#include <vector>

#include "fusion/volume.h"
#include "io/mesh.h"
#include "runtime.pb.h"
#include "stereo/multi_baseline.h"

namespace dome::pipeline {

// Output names of the jobs (runtime.Output.name).
inline constexpr const char* kStereoOutput = "stereo";
inline constexpr const char* kSlabOutput = "slab";
inline constexpr const char* kDecimatedOutput = "mesh_decimated.ply";
inline constexpr const char* kTexturedObj = "textured.obj";
inline constexpr const char* kTexturedMtl = "textured.mtl";
inline constexpr const char* kTexturedPng = "textured.png";
inline constexpr const char* kTexturedGlb = "textured.glb";  // the same mesh, one binary glTF

// Runs one job; `blobs` are the bytes of job.blobs, in the job's order. Returns its
// outputs (names above). `threads` <= 0: all hardware threads.
std::vector<runtime::Output> RunJob(const runtime::Job& job, const std::vector<std::string>& blobs);

// Stereo results <-> the "stereo" blob.
std::string EncodeStereoOutput(const stereo::StereoResult& result);
stereo::StereoResult DecodeStereoOutput(const std::string& bytes, const std::string& where);

// Surface extraction (the master's stage): the slabs of one instant, fetched one at a
// time in plane order by `slab(index)` (index 0 = planes from 0), stitched by
// StreamingMarchingCubes; memory is bounded by one slab.
io::Mesh ExtractSurface(const fusion::VolumeGrid& grid, int num_slabs,
                        const std::function<std::string(int index)>& slab);

// The PLY bytes dome writes for meshes (binary little-endian, "units mm").
std::string EncodeMeshPly(const io::Mesh& mesh);

}  // namespace dome::pipeline
