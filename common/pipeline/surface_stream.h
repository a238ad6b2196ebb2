// The master's surface stage of one instant, streamed (SPEC.md "Pipeline": stitch +
// marching cubes in plane order): a thread that takes the instant's fusion slabs in
// plane order as they finish, each as soon as every slab before it is in, runs the
// surface stage (pipeline/stages.h Surface: StreamingMarchingCubes, one slab in
// memory, then smoothing) over them and writes OUT/<instant>/mesh.ply and its blob.
// When the last slab arrives only its own planes are left to do, so the instant's
// decimation starts almost at once. It is the surface stage's MasterStageRun
// (pipeline/stage.h).
//
// Slabs are read from the master's blobs by address (kept until the surface is
// journalled). Feed() and the accessors are for the master's loop; the extraction runs
// on the stream's own thread, never on the loop.
#pragma once

#include <condition_variable>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "fusion/volume.h"
#include "mesh/smooth.h"
#include "pipeline/stage.h"
#include "runtime.pb.h"

namespace dome::pipeline {

class SurfaceStream : public MasterStageRun {
 public:
  // `dir`: OUT/<instant>; `blobs`: where slabs are read and the mesh blob goes.
  // `smooth`: applied to the whole surface before it is written (mesh/smooth.h).
  // `finished`: called from the stream's thread when it has ended (may be empty).
  SurfaceStream(const fusion::VolumeGrid& grid, int num_slabs, BlobAccess* blobs,
                const std::filesystem::path& dir, const mesh::SmoothOptions& smooth = {},
                std::function<void()> finished = {});
  // Aborts a stream still waiting for slabs and joins its thread.
  ~SurfaceStream() override;
  SurfaceStream(const SurfaceStream&) = delete;
  SurfaceStream& operator=(const SurfaceStream&) = delete;

  // Slab `index` (0 = planes from 0) is in the store under `sha256`; `decoded`, when
  // given, is that slab decoded (the master decodes a result to check it), kept for the
  // stream while it is among the next kDecodedAhead slabs it needs, so that it is not
  // read and decoded again. Feeding an index twice keeps the first.
  void Feed(int index, const std::string& sha256,
            std::shared_ptr<const fusion::Slab> decoded = nullptr);
  // MasterStageRun: outputs[0] is the slab; `decoded` a fusion::Slab or null.
  void Feed(int index, const std::vector<runtime::BlobRef>& outputs,
            std::shared_ptr<const void> decoded) override;
  // Decoded slabs kept ahead of the one the stream waits for (17 MB each for 24 planes
  // of the seed's volume): slabs that finish out of order wait this way.
  static constexpr int kDecodedAhead = 4;
  bool Fed(int index) const;
  // Stops waiting for slabs; the stream then ends with an error.
  void Abort() override;

  // True once the stream has ended (mesh written, or an error).
  bool Finished() const override;
  // After Finished(): the mesh blob ("mesh.ply"); throws the stream's error.
  std::vector<runtime::BlobRef> Result() override;
  // Seconds the thread spent working (reading, stitching, writing), waits excluded.
  double busy_seconds() const override;

 private:
  void Run();
  void WaitForSlab(int index);
  std::shared_ptr<const fusion::Slab> TakeSlab(int index);

  const fusion::VolumeGrid grid_;
  const mesh::SmoothOptions smooth_;
  BlobAccess* blobs_;
  const std::filesystem::path dir_;
  const std::function<void()> finished_callback_;
  mutable std::mutex mutex_;
  std::condition_variable fed_cv_;
  std::vector<std::string> slabs_;                            // sha256 per index, "" until fed
  std::vector<std::shared_ptr<const fusion::Slab>> decoded_;  // per index, when kept
  int next_ = 0;                                              // the index waited for
  bool abort_ = false;
  bool finished_ = false;
  double busy_s_ = 0;
  std::optional<runtime::BlobRef> mesh_;
  std::string error_;
  std::thread thread_;  // last: starts after the members it uses
};

}  // namespace dome::pipeline
